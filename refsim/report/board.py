"""The overview as read at a glance: one line per engine, then the scoreboard as an HTML table
grouped by model group, each cell coloured by log10(best error / target) with its word.

Legibility is built in, not hoped for: cell text 13 px; on every cell colour the text is
black or white, whichever has the higher WCAG contrast ratio (at least 4.5 on the colour
scale used: `contrast` checks it, tests/harness/test_report.py measures it in Chromium);
the colour scale is a labelled legend of swatches; the two verdicts are two marks (the
target's word on the first line, the method's mark on the second); the colour's side
always agrees with the word (a cell reaches the target exactly when its best error is at
most the target, so its ratio is at most 0: green side).
"""
from __future__ import annotations

import functools
import html
import math
import re
from collections import Counter

RATIO_SPAN = 4.0  # the colour scale covers log10(best / target) in [-4, 4] (clipped beyond)
GAP = 0.15  # of the colour map's [0, 1] left out around its middle
GREY = "#d9d9d9"  # unsupported, not run
LEGEND_STEPS = (-4, -3, -2, -1, 0, 1, 2, 3, 4)


def colour(ratio: float) -> str:
    """The scale's colour at log10(best / target) (matplotlib's RdYlGn reversed: green
    below the target, red above)."""
    if not math.isfinite(ratio):
        return GREY
    # a gap around the scale's yellow middle: a cell just under the target is light green,
    # one just over it light orange, never the same colour on both sides of the word
    side = 1.0 if ratio > 0 else -1.0
    x = 0.5 + side * (GAP + (0.5 - GAP) * min(abs(ratio), RATIO_SPAN) / RATIO_SPAN)
    r, g, b, _ = _colour_map()(x)
    return "#%02x%02x%02x" % (round(r * 255), round(g * 255), round(b * 255))


@functools.cache
def _colour_map():
    """RdYlGn reversed (matplotlib's registry copies the map at every look-up)."""
    from matplotlib import colormaps
    return colormaps["RdYlGn_r"]


def luminance(hex_colour: str) -> float:
    """WCAG 2 relative luminance of '#rrggbb'."""
    def channel(c):
        c = c / 255
        return c / 12.92 if c <= 0.03928 else ((c + 0.055) / 1.055) ** 2.4
    r, g, b = (int(hex_colour[k:k + 2], 16) for k in (1, 3, 5))
    return 0.2126 * channel(r) + 0.7152 * channel(g) + 0.0722 * channel(b)


def contrast(a: str, b: str) -> float:
    """WCAG 2 contrast ratio of two '#rrggbb' colours (1 to 21)."""
    la, lb = sorted((luminance(a), luminance(b)), reverse=True)
    return (la + 0.05) / (lb + 0.05)


def text_colour(background: str) -> str:
    return max(("#000000", "#ffffff"), key=lambda t: contrast(t, background))


def ratio_of(r) -> float:
    """log10(best error / target) of a scoreboard row (NaN where nothing ran or no target)."""
    if math.isfinite(r["best"]) and math.isfinite(r["target"]) and r["target"] > 0:
        return math.log10(max(r["best"], 1e-300) / r["target"])
    return math.nan


def _refusal_phrases(notes, engine: str) -> str:
    """The refusals' first clauses without the engine's name, counted; the "does not
    simulate X" ones gathered: 'no finite-difference grid solver (4); does not simulate fluid,
    flocking (2 each)'."""
    clauses = Counter()
    for note in notes:
        clause = str(note).split(" (")[0].split(";")[0].split(": ")[0].strip().rstrip(".")
        clauses[clause.removeprefix(engine + " ").removeprefix(engine + "'s ")] += 1
    missing = [c.removeprefix("does not simulate ") for c in clauses
               if c.startswith("does not simulate ")]
    out = [f"{c} ({n})" for c, n in clauses.items() if not c.startswith("does not simulate ")]
    if missing:
        out.append("does not simulate " + ", ".join(missing))
    return "; ".join(out)


def engine_lines(board, table) -> list[str]:
    """One sentence per engine: case variants reaching the target of those it runs, rows
    consistent with the method they name, and what it refuses, in one phrase each."""
    out = []
    for engine, cells in board.groupby("engine", sort=False):
        ran = cells[~cells["verdict"].isin(("unsupported", "not run"))]
        reached = int((ran["verdict"] == "reaches the target").sum())
        rows = table[(table["engine"] == engine) & (table["status"] == "ok")]
        counts = rows["consistency"].value_counts() if "consistency" in rows else Counter()
        judged = int(sum(counts.get(k, 0) for k in ("consistent", "inconsistent")))
        parts = [f"**{engine}**: {reached} of {len(ran)} case variants it runs reach the "
                 f"target; {counts.get('consistent', 0)} of {judged} judged rows consistent "
                 f"with the method they name ({counts.get('inconsistent', 0)} inconsistent, "
                 f"{counts.get('unresolved', 0)} unresolved, "
                 f"{counts.get('no method reference', 0)} without a method reference)"]
        refused = cells[cells["verdict"] == "unsupported"]
        if len(refused):
            parts.append(f"refuses {len(refused)}: "
                         + _refusal_phrases(refused["note"], engine))
        failed = int((cells["verdict"] == "not run").sum())
        if failed:
            parts.append(f"{failed} failed to run")
        out.append(", ".join(parts) + ".")
    return out


def _cell_html(r) -> str:
    if r["verdict"] in ("unsupported", "not run"):
        word = "unsupported" if r["verdict"] == "unsupported" else "failed"
        title = html.escape(str(r["note"]), quote=True)
        return (f'<td class="sb" style="background:{GREY};color:#000000" title="{title}">'
                f"{word}</td>")
    ratio = ratio_of(r)
    background = colour(ratio)
    word = "reaches" if r["verdict"] == "reaches the target" else "SHORT"
    best = f"{r['best']:.0e}" + (" (round-off)" if r["best"] <= r["floor"] else "")
    method = str(r["method"])
    mark = (f"✗ {r['inconsistent']} inconsistent" if r["inconsistent"] else
            "✓ method" if re.search(r"\b\d+ consistent", method) else
            "? unresolved" if "unresolved" in method else "~ no method bound")
    title = html.escape(f"best {r['best']:.3g} at {r['best_at']}; {r['method']}", quote=True)
    return (f'<td class="sb" style="background:{background};color:{text_colour(background)}" '
            f'title="{title}"><b>{word}</b> {best}<br>{mark}</td>')


def board_html(board) -> str:
    """The scoreboard table: a heading row per model group, a row per case variant, a
    column per engine; then the legend of the colour scale."""
    engines = list(dict.fromkeys(board["engine"]))
    head = "".join(f"<th>{html.escape(e)}</th>" for e in engines)
    rows = [f'<table class="board"><tr><th>case / variant</th>{head}</tr>']
    for group, cells in board.groupby("model_group", sort=False):
        rows.append(f'<tr><th class="group" colspan="{len(engines) + 1}">model group '
                    f"{html.escape(str(group))}</th></tr>")
        for case, row_cells in cells.groupby("case", sort=False):
            by_engine = {r["engine"]: r for _, r in row_cells.iterrows()}
            tds = "".join(_cell_html(by_engine[e]) if e in by_engine else
                          '<td class="sb" style="background:#ffffff;color:#000000">-</td>'
                          for e in engines)
            rows.append(f'<tr><td class="case">{html.escape(case)}</td>{tds}</tr>')
    rows.append("</table>")
    return "".join(rows) + legend_html()


def legend_html() -> str:
    swatches = "".join(
        f'<td class="sb" style="background:{colour(k)};color:{text_colour(colour(k))}">'
        f"{'+' if k > 0 else ''}{k}</td>" for k in LEGEND_STEPS)
    return ('<table class="legend"><tr><th>colour: log10(best error / target)</th>'
            f'<td class="sb">below target (green) &larr;</td>{swatches}'
            '<td class="sb">&rarr; above target (red)</td>'
            f'<td class="sb" style="background:{GREY};color:#000000">not run</td></tr></table>')
