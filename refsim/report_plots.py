"""The report's figures, drawn from a stored run's table and time series (matplotlib, Agg).

Each function takes the rows of one case variant and writes one PNG, returning its path, or
None when there is nothing to draw (no `ok` row, no stored series).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

DPI = 100
SIZE = (10.0, 4.6)  # the legend sits right of the axes


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def line_label(row) -> str:
    ev = row["engine_variant"]
    return f"{row['engine']}{':' + ev if ev else ''} {row['integrator']}"


def _lines(rows: pd.DataFrame, column: str):
    """(label, sub-table sorted by dt) per engine x formulation x integrator with >= 1 finite,
    positive value in `column`."""
    ok = rows[(rows["status"] == "ok") & np.isfinite(rows[column]) & (rows[column] > 0)]
    for key, sub in ok.groupby(["engine", "engine_variant", "integrator"], sort=False):
        yield line_label(sub.iloc[0]), sub.sort_values("dt")


def pareto_front(err: np.ndarray, cost: np.ndarray) -> np.ndarray:
    """Indices of the points no other point beats in both error and cost, by rising error."""
    order = np.lexsort((cost, err))
    front, best = [], np.inf
    for k in order:
        if cost[k] < best:
            front.append(k)
            best = cost[k]
    return np.asarray(front, int)


def _finish(fig, ax, path: Path, title: str) -> Path:
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.25)
    handles, _ = ax.get_legend_handles_labels()
    if handles:
        ax.legend(fontsize=6.5, ncol=1 + len(handles) // 24, loc="upper left",
                  bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, frameon=False)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)
    _pyplot().close(fig)
    return path


def work_precision(rows, err_col, units, path: Path, title: str):
    """Error (log x) against run time to t_end (log y), one line per engine and integrator
    across the dt sweep; the Pareto front over every point drawn as a black step line."""
    timed = rows[np.isfinite(rows["step_s"]) & (rows["step_s"] > 0)]
    lines = list(_lines(timed, err_col))
    if not lines:
        return None
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=SIZE)
    for label, sub in lines:
        ax.loglog(sub[err_col], sub["step_s"], "o-", ms=3, lw=1, label=label)
    pts = pd.concat([sub for _, sub in lines])
    err, cost = pts[err_col].to_numpy(float), pts["step_s"].to_numpy(float)
    front = pareto_front(err, cost)
    ax.step(err[front], cost[front], "k--", where="post", lw=1.2, label="Pareto front")
    ax.plot(err[front], cost[front], "ks", mfc="none", ms=7)
    ax.set_xlabel(f"{err_col} ({units})")
    ax.set_ylabel("run time to t_end (s)")
    return _finish(fig, ax, path, title)


def convergence(rows, err_col, units, path: Path, title: str):
    """Error against dt (log-log), the legend giving each line's fitted order."""
    lines = [(lab, sub) for lab, sub in _lines(rows, err_col) if sub["dt"].nunique() > 1]
    if not lines:
        return None
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=SIZE)
    for label, sub in lines:
        order = sub["order"].iloc[0] if "order" in sub else np.nan
        tag = f" (p={order:.2f})" if np.isfinite(order) else ""
        ax.loglog(sub["dt"], sub[err_col], "o-", ms=3, lw=1, label=label + tag)
    ax.set_xlabel("dt (s)")
    ax.set_ylabel(f"{err_col} ({units})")
    return _finish(fig, ax, path, title)


def _traced(rows, series: dict, key_of, field: str):
    """(row, its stored time series) for every row whose series holds `field`."""
    for _, row in rows.iterrows():
        trace = series.get(key_of(row))
        if trace and field in trace:
            yield row, trace


def energy_history(rows, series: dict, key_of, scale: float, path: Path, title: str):
    """|E(t) - E(0)| / energy scale at the reference dt (log scale, round-off floored at
    1e-16), one line per engine and integrator."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=SIZE)
    drawn = 0
    for row, trace in _traced(rows, series, key_of, "energy"):
        e = np.asarray(trace["energy"], float)
        ax.semilogy(trace["t"][1:], np.maximum(np.abs(e[1:] - e[0]) / scale, 1e-16), lw=1,
                    label=line_label(row))
        drawn += 1
    if not drawn:
        plt.close(fig)
        return None
    ax.set_xlabel("t (s)")
    ax.set_ylabel("|E(t) - E(0)| / energy scale")
    return _finish(fig, ax, path, title)


def trace_over_data(rows, series: dict, key_of, spec: dict, path: Path, title: str):
    """A case's declared figure (Case.figures, kind "trace_over_data"): each row's stored
    series spec["y"] against spec["x"] (shifted by the row's spec["x_shift_column"] when
    given), over the measured points spec["data"]."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=SIZE)
    drawn = 0
    column = spec.get("x_shift_column")
    for row, trace in _traced(rows, series, key_of, spec["y"]):
        shift = float(row.get(column, 0.0)) if column else 0.0
        shift = 0.0 if not np.isfinite(shift) else shift
        label = line_label(row)
        if column:
            label += f" (shift {shift:+.2f}, RMS {row['err_rms']:.3f})"
        ax.plot(np.asarray(trace[spec["x"]]) + shift, trace[spec["y"]], lw=1.2, label=label)
        drawn += 1
    if not drawn:
        plt.close(fig)
        return None
    data = spec["data"]
    ax.plot(data["x"], data["y"], "ko", ms=4, mfc="none", label=data["label"])
    ax.set_xlabel(spec["x_label"])
    ax.set_ylabel(spec["y_label"])
    return _finish(fig, ax, path, title)


FIGURES = {"trace_over_data": trace_over_data}  # the kinds a case may declare
