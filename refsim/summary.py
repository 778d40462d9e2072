"""What `refsim run` prints: a progress bar on a terminal and a compact summary table."""
from __future__ import annotations

import sys
import time

import numpy as np
import pandas as pd


def progress_printer(stream=sys.stderr):
    """A one-line progress bar when `stream` is a terminal; silent otherwise."""
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
    from cases import get_case
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


def print_summary(table: pd.DataFrame, stream=sys.stdout) -> None:
    rows = reference_rows(table)
    header = (f"{'case':13s} {'variant':15s} {'engine':20s} {'integrator':20s} {'dt':>9s} "
              f"{'err_max':>9s} {'tol':>9s} {'E drift':>9s} {'order':>6s} {'us/step':>8s} status")
    print(header, file=stream)
    print("-" * len(header), file=stream)
    for _, r in rows.iterrows():
        engine = r["engine"] + (f":{r['engine_variant']}" if r["engine_variant"] else "")
        status = r["status"] if r["status"] != "ok" else ("ok" if r["within_tol"] in
                                                          (True, "True") else "ok>tol")
        if r["status"] != "ok":
            status += f" ({str(r['reason'])[:50]})"
        print(f"{r['case']:13s} {r['variant']:15s} {engine:20s} {str(r['integrator']):20s} "
              f"{_fmt(r['dt'], '9.3g')} {_fmt(r['err_max'], '9.2e')} "
              f"{_fmt(r['tolerance'], '9.2e')} {_fmt(r['energy_drift'], '9.2e')} "
              f"{_fmt(r['order'], '6.2f')} {_fmt(r['us_per_step'], '8.2f')} {status}",
              file=stream)
    counts = table["status"].value_counts().to_dict()
    print(f"{len(table)} rows: " + ", ".join(f"{k} {v}" for k, v in counts.items()), file=stream)
