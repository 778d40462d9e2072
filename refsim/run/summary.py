"""What `refsim run` prints: a progress bar on a terminal and a compact summary table."""
from __future__ import annotations

import sys
import time

import numpy as np
import pandas as pd


def progress_printer(stream=None):
    """A one-line progress bar when `stream` (default: sys.stderr at call time, not at import:
    a stream swapped since, as under pytest's capture, may be closed) is a terminal; silent
    otherwise."""
    stream = sys.stderr if stream is None else stream
    if not stream.isatty():
        return None
    start = time.perf_counter()

    def show(done, total, job):
        width = 28
        filled = int(width * done / max(total, 1))
        label = job.label if job else "done"
        elapsed = time.perf_counter() - start
        stream.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total} "
                     f"{elapsed:5.0f}s {label[:60]:60s}")
        if job is None:
            stream.write("\n")
        stream.flush()
    return show


def _fmt(value, spec):
    return "-" if value is None or (isinstance(value, float) and not np.isfinite(value)) \
        else format(value, spec)


def _truthy(value) -> bool:
    return value in (True, "True")


FLAGS = {"consistent": "", "inconsistent": "!", "unresolved": "?", "no method reference": "~"}


def _cell(r) -> str:
    """err_max, energy drift and us/step of one row, or its status when not ok. The flags:
    '!' inconsistent with its method, '?' unresolved (the method's bound is not below the
    motion: no verdict), '~' no method reference (an engine's own scheme); '*' the error
    reaches the case's target."""
    if r["status"] != "ok":
        return f"{r['status']:^26s}"
    flag = FLAGS.get(str(r.get("consistency", "")), "")
    flag += "*" if _truthy(r.get("reaches_target")) else ""
    return (f"{_fmt(r['err_max'], '8.1e')}{flag:2s}{_fmt(r['energy_drift'], '7.1e')} "
            f"{_fmt(r['us_per_step'], '8.3g')}")


def verdict_counts(table: pd.DataFrame) -> dict:
    """The ok rows by their consistency verdict, and how many reach the case's target."""
    from refsim.verdicts import CONSISTENCY, upgrade_table
    ok = upgrade_table(table)
    ok = ok[ok["status"] == "ok"]
    counts = {name: int((ok["consistency"] == name).sum()) for name in CONSISTENCY}
    reach = ok["reaches_target"].map(_truthy) if "reaches_target" in ok else None
    counts["reach the target"] = int(reach.sum()) if reach is not None else 0
    return counts


def print_summary(table: pd.DataFrame, stream=None) -> None:
    """Per case and variant: every engine and integrator side by side at each dt (err_max with
    its flags (see _cell), energy drift, us/step) with the measured convergence order; rows
    that did not run show their status and reason once. The last line counts the rows by
    status, the ok ones by consistency verdict and by reaching the target.
    `stream` defaults to sys.stdout at call time (see progress_printer)."""
    stream = sys.stdout if stream is None else stream
    for (case, variant), group in table.groupby(["case", "variant"], sort=False):
        dts = sorted((d for d in group["dt"].unique() if np.isfinite(d)), reverse=True)
        print(f"\n{case} / {variant}", file=stream)
        pad = " " * 50
        print(pad + " | ".join(f"dt = {d:.4g} s".center(26) for d in dts), file=stream)
        print(f"  {'engine':20s} {'integrator':20s} {'order':>6s} " + " | ".join(
            f"{'err_max':>9s} {'E_drift':>7s} {'us/step':>8s}" for _ in dts), file=stream)
        notes = []
        for (engine, ev, integ), sub in group.groupby(["engine", "engine_variant", "integrator"],
                                                      sort=False, dropna=False):
            label = engine + (f":{ev}" if ev else "")
            if not np.isfinite(sub["dt"]).any():
                notes.append(f"  {label}: {sub['status'].iloc[0]} ({sub['reason'].iloc[0]})")
                continue
            by_dt = {d: r for d, r in zip(sub["dt"], sub.to_dict("records"))}
            cells = [_cell(by_dt[d]) if d in by_dt else f"{'':26s}" for d in dts]
            print(f"  {label:20s} {str(integ):20s} {_fmt(sub['order'].iloc[0], '6.2f')} "
                  + " | ".join(cells), file=stream)
        for note in notes:
            print(note, file=stream)
    counts = table["status"].value_counts().to_dict()
    verdicts = ", ".join(f"{k} {v}" for k, v in verdict_counts(table).items())
    print("\nflags after err_max: ! inconsistent with its method, ? unresolved at that dt, "
          "~ no method reference (the engine's own scheme), * reaches the case's target",
          file=stream)
    print(f"{len(table)} rows: " + ", ".join(
        f"{k} {v}" + (f" ({verdicts})" if k == "ok" else "") for k, v in counts.items()),
        file=stream)
