"""The report's first section: a scoreboard of case/variant x engine and its heatmap.

Read from the store only (the results table and the run's case definitions). One cell per
case, variant and engine: the best error any of the engine's configurations reached, whether
one is within the case's tolerance, the cheapest configuration reaching the case's target
error (integrator, dt, run time), or why nothing ran (`unsupported` with its reason). Rows
carrying `unresolved` (a tolerance capped at the motion scale: never within tolerance) are
counted apart.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from refsim import report_style as rs

VERDICTS = ("pass", "fail", "unresolved", "unsupported", "not run")
TRUE = (True, "True", "true", 1, "1")


def truthy(value) -> bool:
    return value in TRUE or (isinstance(value, (bool, np.bool_)) and bool(value))


def _unresolved(rows: pd.DataFrame) -> pd.Series:
    if "unresolved" not in rows:
        return pd.Series(False, index=rows.index)
    return rows["unresolved"].map(truthy)


def _config(row) -> str:
    form = f":{row['engine_variant']}" if row["engine_variant"] else ""
    return f"{row['integrator']}{form} at dt = {row['dt']:.3g} s"


def cell(rows: pd.DataFrame, col: str, target: float) -> dict:
    """The scoreboard cell of one engine's rows of one case variant."""
    ok = rows[(rows["status"] == "ok") & np.isfinite(rows[col].astype(float))]
    out = {"verdict": "", "best": math.nan, "cheapest": "", "run_time": math.nan, "note": ""}
    if ok.empty:
        statuses = rows["status"].value_counts()
        first = rows[rows["status"] == statuses.index[0]].iloc[0]
        verdict = "unsupported" if statuses.index[0] == "unsupported" else "not run"
        note = f"{first['status']}: {first['reason']}" if verdict == "not run" else \
            str(first["reason"])
        return {**out, "verdict": verdict, "note": note}
    unresolved = _unresolved(ok)
    within = ok["within_tol"].map(truthy) & ~unresolved
    out["best"] = float(ok[col].min())
    if within.any():
        out["verdict"] = "pass"
    else:
        out["verdict"] = "unresolved" if unresolved.any() else "fail"
    if unresolved.any():
        out["note"] = f"{int(unresolved.sum())} of {len(ok)} unresolved (capped tolerance)"
    timed = ok[np.isfinite(ok["step_s"].astype(float))]
    good = timed[timed[col] <= target] if math.isfinite(target) else timed.iloc[:0]
    if len(good):
        best = good.loc[good["step_s"].astype(float).idxmin()]
        out["cheapest"], out["run_time"] = _config(best), float(best["step_s"])
    elif math.isfinite(target):
        out["cheapest"] = "none reaches the target"
    return out


def scoreboard(table: pd.DataFrame, definitions, target_error=None) -> pd.DataFrame:
    """One row per case x variant x engine: verdict, best error, target, cheapest config."""
    out = []
    for _, rows in table.groupby(["case", "variant", "params"], sort=False, dropna=False):
        d = definitions.of_row(rows.iloc[0])
        col = d["tolerance_column"]
        target = target_error if target_error is not None else float(d["target_error"])
        for engine, sub in rows.groupby("engine", sort=False):
            out.append({"case": f"{d['case']} / {d['variant']}", "engine": engine,
                        "column": col, "target": target, "floor": float(d["error_floor"]),
                        **cell(sub, col, target)})
    return pd.DataFrame(out)


def _error_text(value: float, floor: float) -> str:
    if not math.isfinite(value):
        return "-"
    return f"{value:.2e}" + (" (round-off)" if value <= floor else "")


def scoreboard_table(board: pd.DataFrame) -> pd.DataFrame:
    """The scoreboard as the report prints it."""
    return pd.DataFrame({
        "case / variant": board["case"], "engine": board["engine"],
        "verdict": board["verdict"],
        "best error": [f"{_error_text(b, f)} {c}" if math.isfinite(b) else "-"
                       for b, f, c in zip(board["best"], board["floor"], board["column"])],
        "target": [f"{t:.2g}" if math.isfinite(t) else "-" for t in board["target"]],
        "cheapest reaching the target": board["cheapest"].replace("", "-"),
        "run time (s)": [f"{t:.3g}" if math.isfinite(t) else "-" for t in board["run_time"]],
        "note": board["note"].replace("", "-")})


def counts_text(board: pd.DataFrame) -> str:
    counts = board["verdict"].value_counts()
    parts = [f"{counts[v]} {v}" for v in VERDICTS if v in counts]
    return (f"Scoreboard: {len(board)} case x engine cells: " + ", ".join(parts) + ". A cell "
            "passes when one of the engine's configurations is within the case's tolerance; "
            "`unresolved` cells have only capped tolerances (an error the size of the motion "
            "would pass them), never counted as within tolerance.")


def heatmap(board: pd.DataFrame, path: Path, title: str, style=None):
    """Case/variant (rows) x engine (columns): colour log10(best error / target), each cell
    annotated with its verdict; cells that did not run grey."""
    plt = rs._pyplot()
    cases = list(dict.fromkeys(board["case"]))
    engines = list(dict.fromkeys(board["engine"]))
    ratio = np.full((len(cases), len(engines)), np.nan)
    label_in = 0.3 + 0.062 * max((len(c) for c in cases), default=0)  # row labels, 7 pt
    fig, ax = plt.subplots(figsize=(label_in + 1.6 + 1.35 * len(engines),
                                    1.4 + 0.32 * len(cases)))  # 0.9 in title, 0.5 in bottom
    ax.set_facecolor("#bbbbbb")
    for r in board.itertuples(index=False):
        i, j = cases.index(r.case), engines.index(r.engine)
        if math.isfinite(r.best) and math.isfinite(r.target) and r.target > 0:
            ratio[i, j] = np.log10(max(r.best, r.floor, 1e-300) / r.target)
        ax.text(j, i, _annotation(r), ha="center", va="center", fontsize=6.5)
    image = ax.imshow(np.ma.masked_invalid(ratio), cmap="RdYlGn_r", vmin=-4, vmax=4,
                      aspect="auto")
    ax.set_xticks(range(len(engines)), engines, fontsize=8)
    ax.set_yticks(range(len(cases)), cases, fontsize=7)
    ax.xaxis.tick_top()
    bar = fig.colorbar(image, ax=ax, fraction=0.05, pad=0.02)
    bar.set_label("log10(best error / target)", fontsize=7)
    bar.ax.tick_params(labelsize=6.5)
    return rs.save(fig, path, title, left_in=label_in, top_in=0.9)


def _annotation(r) -> str:
    short = {"unsupported": "unsupported", "not run": "failed"}
    if r.verdict in short:
        return short[r.verdict]
    mark = {"pass": "pass", "fail": "FAIL", "unresolved": "unresolved"}[r.verdict]
    return f"{mark}\n{r.best:.0e}" if r.best > r.floor else f"{mark}\nround-off"


def overview_blocks(table, definitions, target_error, out: Path, style=None) -> list:
    """The overview section: counts, the heatmap, the scoreboard table."""
    board = scoreboard(table, definitions, target_error)
    if board.empty:
        return []
    figure = heatmap(board, out / "plots" / "overview.png",
                     "Scoreboard: best error against the case's target", style)
    return [("h2", "Overview", "overview"), ("p", counts_text(board)),
            ("img", figure, "overview: scoreboard heatmap"),
            ("table", scoreboard_table(board))]
