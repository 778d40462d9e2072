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


def reference_rows(table: pd.DataFrame) -> pd.DataFrame:
    """One row per case x variant x engine x integrator: the one at the case's reference dt
    (or the finest dt run when the reference dt was not in the sweep)."""
    from refsim.registry import get_case
    import json
    picked = []
    for key, group in table.groupby(["case", "variant", "params"], dropna=False, sort=False):
        case = get_case(key[0])
        ref_dt = case.reference_dt(case.variant_params(key[1], json.loads(key[2])))
        for _, sub in group.groupby(["engine", "engine_variant", "integrator"], sort=False):
            dts = sub["dt"].to_numpy(float)
            if np.all(np.isnan(dts)):
                picked.append(sub.index[0])
                continue
            picked.append(sub.index[int(np.nanargmin(np.abs(np.log(dts / ref_dt))))])
    return table.loc[picked]


def _truthy(value) -> bool:
    return value in (True, "True")


def _cell(r) -> str:
    """err_max, energy drift and us/step of one row, or its status when not ok. The flag: '?'
    unresolved (the derived bound is not below the motion: no accuracy verdict), '!' above
    the tolerance."""
    if r["status"] != "ok":
        return f"{r['status']:^26s}"
    flag = "?" if _truthy(r.get("unresolved")) else "" if _truthy(r["within_tol"]) else "!"
    return (f"{_fmt(r['err_max'], '8.1e')}{flag:1s} {_fmt(r['energy_drift'], '7.1e')} "
            f"{_fmt(r['us_per_step'], '8.3g')}")


def verdict_counts(table: pd.DataFrame) -> dict:
    """The ok rows split by verdict: within tolerance, above it, unresolved (counted apart:
    an unresolved row is never within tolerance)."""
    ok = table[table["status"] == "ok"]
    unresolved = (ok["unresolved"].map(_truthy) if "unresolved" in ok
                  else pd.Series(False, index=ok.index))
    within = ok["within_tol"].map(_truthy) & ~unresolved
    return {"within tolerance": int(within.sum()),
            "above tolerance": int((~within & ~unresolved).sum()),
            "unresolved": int(unresolved.sum())}


def print_summary(table: pd.DataFrame, stream=None) -> None:
    """Per case and variant: every engine and integrator side by side at each dt (err_max,
    energy drift, us/step; '!' marks an error above the case tolerance) with the measured
    convergence order; rows that did not run show their status and reason once. The last line
    counts the rows by status, the ok ones by verdict ('?' unresolved, counted apart).
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
    print(f"\n{len(table)} rows: " + ", ".join(
        f"{k} {v}" + (f" ({verdicts})" if k == "ok" else "") for k, v in counts.items()),
        file=stream)
