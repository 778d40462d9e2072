"""The stress run's figure: the largest stable step of each engine x integrator, measured
against theory (a case's declared figure, kind "stability_limits", drawn from the rows that
`refsim stress` stores: columns `measured` and `theory` in the case's stability parameter).

One horizontal line per (integrator, engine[:formulation]), grouped by integrator in order of
the theory's limit: a filled marker in the engine's colour at the measured limit, a black bar
at the theory's, and an arrow at the right edge for a limit that is unbounded (stable to the
search's largest y). A failed search is drawn as a grey cross at the left edge, labelled.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from refsim.report import style as rs

ROW_IN = 0.2  # inches per line of the figure
UNBOUNDED = "stable at every y searched"


def stability_limits(rows, series, key_of, spec: dict, path: Path, title: str, style=None):
    """See the module docstring; None when no row holds a measured or theoretical limit."""
    if "measured" not in rows or "theory" not in rows:
        return None
    table = rows.assign(measured=rows["measured"].astype(float),
                        theory=rows["theory"].astype(float))
    # inf is a result (stable at every y searched), NaN is none
    table = table[~np.isnan(table["measured"]) | ~np.isnan(table["theory"])
                  | (table["status"] != "ok")]
    if table.empty:
        return None
    style = style or rs.Style.of_table(table)
    order = table.groupby("integrator")["theory"].min().sort_values(na_position="last")
    table = table.assign(rank=table["integrator"].map({n: k for k, n in enumerate(order.index)}))
    table = table.sort_values(["rank", "engine", "engine_variant"]).reset_index(drop=True)
    finite = np.concatenate([table["measured"].to_numpy(), table["theory"].to_numpy()])
    finite = finite[np.isfinite(finite)]
    right = 1.15 * float(finite.max()) if finite.size else 1.0
    plt = rs._pyplot()
    fig, ax = plt.subplots(figsize=(rs.PANEL[0] * 1.8, 0.9 + ROW_IN * len(table)))
    for k, row in table.iterrows():
        y = len(table) - 1 - k
        _theory_bar(ax, y, row["theory"], right)
        _measured_marker(ax, y, row, right, style)
    labels = [f"{r['integrator']} - {rs.engine_label(r['engine'], r['engine_variant'])}"
              for _, r in table.iterrows()]
    ax.set_yticks(range(len(table)))
    ax.set_yticklabels(labels[::-1], fontsize=6.5)
    ax.set_ylim(-0.7, len(table) - 0.3)
    ax.set_xlim(0.0, right * 1.04)
    ax.set_xlabel(spec.get("x_label", "largest stable step"), fontsize=7)
    _integrator_bands(ax, table)
    for engine in dict.fromkeys(table["engine"]):
        ax.plot([], [], "o", color=style.colour(engine), ms=5, label=engine)
    ax.plot([], [], "|", color="black", ms=9, mew=2, label="theory")
    ax.plot([], [], ">", color="#777777", label=UNBOUNDED)
    rs.finish_axes(ax, "", legend=False)
    handles, names = ax.get_legend_handles_labels()
    ax.legend(handles, names, fontsize=6, frameon=False, loc="lower center",
              bbox_to_anchor=(0.5, 1.0), ncol=math.ceil(len(names) / 2), borderaxespad=0.2)
    ax.grid(True, axis="x", alpha=0.25)
    return rs.save(fig, path, title, left_in=2.3)


def _theory_bar(ax, y: float, theory: float, right: float) -> None:
    if math.isfinite(theory):
        ax.plot([theory], [y], "|", color="black", ms=9, mew=2, zorder=3)
    elif theory == math.inf:
        ax.plot([right], [y], "4", color="black", ms=9, mew=1.5, zorder=3)


def _measured_marker(ax, y: float, row, right: float, style) -> None:
    measured = float(row["measured"])
    if row["status"] != "ok" or math.isnan(measured):
        ax.plot([0.0], [y], "x", color="#888888", ms=6, zorder=4, clip_on=False)
        ax.text(0.02 * right, y, f" {row['status']}: {str(row.get('reason', ''))[:60]}",
                fontsize=5.5, va="center", color="#555555")
        return
    colour = style.colour(row["engine"])
    if math.isinf(measured):
        ax.plot([right], [y], ">", color=colour, ms=6, zorder=4, clip_on=False)
    else:
        ax.plot([measured], [y], "o", color=colour, ms=5, zorder=4)


def _integrator_bands(ax, table) -> None:
    """Alternate grey bands, one per integrator, so that its engines read as a group."""
    n = len(table)
    for k, (_, members) in enumerate(table.groupby("rank", sort=True)):
        if k % 2:
            top, bottom = n - 1 - members.index.min(), n - 1 - members.index.max()
            ax.axhspan(bottom - 0.5, top + 0.5, color="#f0f0f0", zorder=0)
