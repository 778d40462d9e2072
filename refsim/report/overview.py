"""The report's first section: a scoreboard of case/variant x engine and its heatmap.

Read from the store only (the results table and the run's case definitions). One cell per
case, variant and engine answers the two questions apart:
- the target: the cheapest configuration (integrator, dt, run time) whose error reaches the
  case's target ("reaches the target"), or "does not reach the target" with the best error
  and where it was reached; why nothing ran otherwise (`unsupported` with its reason);
- the method: how many of the engine's rows are consistent with the method they name,
  inconsistent, unresolved (the method's bound not below the motion at that dt) or without a
  method reference (the engine's own scheme).
The heatmap's colour and word both come from the target question; the consistency counts
are the cell's second line.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from refsim.report import style as rs

VERDICTS = ("reaches the target", "does not reach the target", "unsupported", "not run")
TARGET_WORDS = {"reaches the target": "reaches", "does not reach the target": "SHORT"}
TRUE = (True, "True", "true", 1, "1")


def truthy(value) -> bool:
    return value in TRUE or (isinstance(value, (bool, np.bool_)) and bool(value))


def _config(row) -> str:
    form = f":{row['engine_variant']}" if row["engine_variant"] else ""
    return f"{row['integrator']}{form} at dt = {row['dt']:.3g} s"


def method_counts(ok: pd.DataFrame) -> str:
    """'12 consistent, 2 inconsistent (rk4 at dt = 0.02 s: reason), 1 unresolved'."""
    if "consistency" not in ok:
        return "-"
    counts = ok["consistency"].value_counts()
    parts = [f"{counts[v]} {v}" for v in ("consistent", "inconsistent", "unresolved",
                                           "no method reference") if v in counts]
    bad = ok[ok["consistency"] == "inconsistent"]
    if len(bad):
        first = bad.iloc[0]
        parts[[p.endswith("inconsistent") for p in parts].index(True)] += (
            f" (first: {_config(first)}: {first.get('consistency_reason', '')})")
    return ", ".join(parts) or "-"


def cell(rows: pd.DataFrame, col: str, target: float) -> dict:
    """The scoreboard cell of one engine's rows of one case variant."""
    ok = rows[(rows["status"] == "ok") & np.isfinite(rows[col].astype(float))]
    out = {"verdict": "", "best": math.nan, "best_at": "", "cheapest": "",
           "run_time": math.nan, "method": "-", "inconsistent": 0, "note": ""}
    if ok.empty:
        statuses = rows["status"].value_counts()
        first = rows[rows["status"] == statuses.index[0]].iloc[0]
        verdict = "unsupported" if statuses.index[0] == "unsupported" else "not run"
        note = f"{first['status']}: {first['reason']}" if verdict == "not run" else \
            str(first["reason"])
        return {**out, "verdict": verdict, "note": note}
    best = ok.loc[ok[col].astype(float).idxmin()]
    out.update(best=float(best[col]), best_at=_config(best), method=method_counts(ok),
               inconsistent=int((ok.get("consistency", pd.Series(dtype=str))
                                 == "inconsistent").sum()))
    timed = ok[np.isfinite(ok["step_s"].astype(float))]
    good = timed[timed[col] <= target] if math.isfinite(target) else timed.iloc[:0]
    if len(good):
        cheapest = good.loc[good["step_s"].astype(float).idxmin()]
        out.update(verdict="reaches the target", cheapest=_config(cheapest),
                   run_time=float(cheapest["step_s"]))
    elif math.isfinite(target) and out["best"] <= target:
        # only untimed rows (the order fit's extra dts) reach it: the word follows the error
        out.update(verdict="reaches the target", cheapest="an untimed order dt only")
    else:
        out["verdict"] = "does not reach the target"
    return out


def scoreboard(table: pd.DataFrame, definitions, target_error=None) -> pd.DataFrame:
    """One row per case x variant x engine: verdict, best error, target, cheapest config,
    sorted by model group (first seen first), in the run's order within a group."""
    from refsim.store.definitions import model_group
    out = []
    for _, rows in table.groupby(["case", "variant", "params"], sort=False, dropna=False):
        d = definitions.of_row(rows.iloc[0])
        col = d["tolerance_column"]
        target = target_error if target_error is not None else float(d["target_error"])
        for engine, sub in rows.groupby("engine", sort=False):
            group = d.get("model_group") or model_group(definitions, d["case"])
            out.append({"case": f"{d['case']} / {d['variant']}", "engine": engine,
                        "model_group": group, "column": col, "target": target,
                        "floor": float(d["error_floor"]),
                        **cell(sub, col, target)})
    board = pd.DataFrame(out)
    if board.empty:
        return board
    order = {g: k for k, g in enumerate(dict.fromkeys(board["model_group"]))}
    return board.sort_values("model_group", key=lambda g: g.map(order), kind="stable",
                             ignore_index=True)


def _error_text(value: float, floor: float) -> str:
    if not math.isfinite(value):
        return "-"
    return f"{value:.2e}" + (" (round-off)" if value <= floor else "")


def scoreboard_table(board: pd.DataFrame) -> pd.DataFrame:
    """The scoreboard as the report prints it: the target question, then the method one."""
    return pd.DataFrame({
        "model group": board["model_group"],
        "case / variant": board["case"], "engine": board["engine"],
        "target": [f"{v} ({t:.2g})" if math.isfinite(t) and v in TARGET_WORDS else v
                   for v, t in zip(board["verdict"], board["target"])],
        "cheapest reaching the target": board["cheapest"].replace("", "-"),
        "run time (s)": [f"{t:.3g}" if math.isfinite(t) else "-" for t in board["run_time"]],
        "best error (where)": [f"{_error_text(b, f)} {c} ({w})" if math.isfinite(b) else "-"
                               for b, f, c, w in zip(board["best"], board["floor"],
                                                     board["column"], board["best_at"])],
        "consistent with the method named": board["method"],
        "note": board["note"].replace("", "-")})


LEGEND = ("Each cell answers two questions. *Target*: does any configuration of the engine "
          "reach the case's declared accuracy target (its \"good enough\", in the error "
          "column named)? The cheapest that does is named, with its run time; otherwise the "
          "best error and where. *Method*: does each row behave as the method it names (rk4 "
          "as RK4) at its dt: its error within the bound a correct implementation of that "
          "method must meet there (the exact discrete solution where the case has one), the "
          "state at t = 0 exact, the fitted order not below the method's, and a symplectic "
          "method's energy error bounded on a conservative scene? `consistent`, "
          "`inconsistent` (with the first reason), `unresolved` (the method's bound is not "
          "below half the motion at that dt, or the case states none: no verdict), "
          "`no method reference` (the engine's "
          "own scheme: only the target question is answered). In the heatmap the colour is "
          "log10(best error / target) (green: below the target) and the word the target "
          "answer; the second line counts the inconsistent rows.")


def counts_text(board: pd.DataFrame) -> str:
    counts = board["verdict"].value_counts()
    parts = [f"{counts[v]} {v}" for v in VERDICTS if v in counts]
    flagged = int((board["inconsistent"] > 0).sum())
    return (f"Scoreboard: {len(board)} case x engine cells: " + ", ".join(parts) +
            f"; {flagged} cells have rows inconsistent with the method they name. " + LEGEND)


def heatmap(board: pd.DataFrame, path: Path, title: str, style=None):
    """Case/variant (rows) x engine (columns): colour log10(best error / target), each cell
    annotated with its target answer and its count of inconsistent rows; cells that did not
    run grey."""
    from refsim.report.board import GREY, LEGEND_STEPS, colour, ratio_of, text_colour
    plt = rs._pyplot()
    cases = list(dict.fromkeys(board["case"]))
    engines = list(dict.fromkeys(board["engine"]))
    label_in = 0.3 + 0.075 * max((len(c) for c in cases), default=0)  # row labels, 9 pt
    fig, ax = plt.subplots(figsize=(label_in + 0.6 + 1.6 * len(engines),
                                    1.9 + 0.42 * len(cases)))  # 8-9 pt text at 72 dpi
    for r in board.itertuples(index=False):
        i, j = cases.index(r.case), engines.index(r.engine)
        ran = r.verdict not in ("unsupported", "not run")
        face = colour(ratio_of(r._asdict())) if ran else GREY
        ax.add_patch(plt.Rectangle((j - 0.5, i - 0.5), 1, 1, facecolor=face,
                                   edgecolor="white"))
        ax.text(j, i, _annotation(r), ha="center", va="center", fontsize=8,
                color=text_colour(face))
    ax.set_xlim(-0.5, len(engines) - 0.5)
    ax.set_ylim(len(cases) - 0.5, -0.5)
    ax.set_xticks(range(len(engines)), engines, fontsize=9)
    ax.set_yticks(range(len(cases)), cases, fontsize=9)
    ax.xaxis.tick_top()
    scale = "   ".join(f"{k:+d}" if k else "0" for k in LEGEND_STEPS)
    ax.set_xlabel("colour: log10(best error / target), green below the target (" + scale
                  + "), red above; grey: not run", fontsize=9)
    return rs.save(fig, path, title, left_in=label_in, top_in=0.9, colours=64)


def _annotation(r) -> str:
    short = {"unsupported": "unsupported", "not run": "failed"}
    if r.verdict in short:
        return short[r.verdict]
    mark = TARGET_WORDS[r.verdict]
    best = f"{r.best:.0e}" if r.best > r.floor else "round-off"
    method = f"\n{r.inconsistent} inconsistent" if r.inconsistent else ""
    return f"{mark}\n{best}{method}"


def overview_blocks(table, definitions, target_error, out: Path, style=None) -> list:
    """The overview section: one line per engine, the scoreboard (a coloured HTML table;
    in Markdown the heatmap figure), the legend, the scoreboard's full text table."""
    from refsim.report.board import board_html, engine_lines
    board = scoreboard(table, definitions, target_error)
    if board.empty:
        return []
    figure = heatmap(board, out / "plots" / "overview.png",
                     "Scoreboard: best error against the case's target", style)
    return ([("h2", "Overview", "overview")] + [("p", line) for line in
                                                 engine_lines(board, table)]
            + [("html", board_html(board)), ("md_img", figure, "overview: scoreboard heatmap"),
               ("p", counts_text(board)),
               ("details", "Scoreboard, every cell in words", scoreboard_table(board))])
