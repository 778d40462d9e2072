"""How the report's figures look: one colour per engine, one marker and line style per
integrator, small multiples of at most MAX_SERIES series, the "exact to round-off" band, and
compact self-contained PNGs (palette images at a modest dpi).

The palette is computed from the run's own engines and integrators (sorted names), so one
engine keeps its colour in every figure of a report and no engine name is written here.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from refsim.report.render import canvas_class, text_metrics

DPI = 72
MAX_SERIES = 10  # series per axes at most
PANEL = (4.2, 3.0)  # inches per small multiple
COLUMNS = 3  # small multiples per figure row
PALETTE_COLOURS = 16  # colours of the quantised PNG (octree: rare engine colours kept; 48
# made the 12-case default report 2.58 MB, 24 made it 1.97 MB; on the 43-section default run,
# as lossless WebP, 24 colours took 1.10 MB and 16 took 0.93 MB, the five engine colours
# still distinct: compound_pendulum's work-precision figure looked at both ways)
ENGINE_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b",
                  "#e377c2", "#17becf", "#bcbd22", "#7f7f7f")
MARKERS = ("o", "s", "^", "v", "D", "P", "X", "*", "<", ">", "h", "p")
LINE_STYLES = ("-", "--", ":", "-.")
FLOOR_LABEL = "exact to round-off"
BAND_DECADES = 2.0  # the band spans this many decades below the error floor


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


@dataclass
class Style:
    """Colours keyed by engine, (marker, line style) keyed by integrator."""
    engines: list = field(default_factory=list)
    integrators: list = field(default_factory=list)

    @classmethod
    def of_table(cls, table) -> "Style":
        names = lambda col: sorted({str(v) for v in table[col] if str(v)})  # noqa: E731
        return cls(names("engine"), names("integrator"))

    def colour(self, engine: str) -> str:
        if engine not in self.engines:
            self.engines.append(engine)
        return ENGINE_COLOURS[self.engines.index(engine) % len(ENGINE_COLOURS)]

    def marker(self, integrator: str) -> tuple[str, str]:
        """(marker, line style): unique for up to len(MARKERS) x len(LINE_STYLES) names."""
        if integrator not in self.integrators:
            self.integrators.append(integrator)
        k = self.integrators.index(integrator)
        return MARKERS[k % len(MARKERS)], LINE_STYLES[(k // len(MARKERS)) % len(LINE_STYLES)]

    def line_kwargs(self, engine: str, integrator: str) -> dict:
        marker, ls = self.marker(integrator)
        return {"color": self.colour(engine), "marker": marker, "ls": ls, "ms": 3.5, "lw": 1.0}


def engine_label(engine: str, formulation: str) -> str:
    return f"{engine}:{formulation}" if formulation else engine


def panels(series: list) -> list[tuple[str, list]]:
    """Small multiples: [(title, series)] with at most MAX_SERIES series each. `series` holds
    (engine, formulation, ...) tuples; an engine with few series gets one panel, a larger one a
    panel per formulation, split into balanced chunks when still too many."""
    out = []
    for engine in _unique(s[0] for s in series):
        mine = [s for s in series if s[0] == engine]
        if len(mine) <= MAX_SERIES:
            out.append((engine, mine))
            continue
        for form in _unique(s[1] for s in mine):
            part = [s for s in mine if s[1] == form]
            chunks = math.ceil(len(part) / MAX_SERIES)
            size = math.ceil(len(part) / chunks)
            for k in range(chunks):
                tag = f" ({k + 1}/{chunks})" if chunks > 1 else ""
                out.append((engine_label(engine, form) + tag, part[k * size:(k + 1) * size]))
    return out


def _unique(values) -> list:
    return list(dict.fromkeys(values))


def floor_of(floor, errors) -> float:
    """The error floor to draw: the case's, or (none declared) a decade below the smallest
    positive error, 1e-16 when there is none."""
    if floor is not None and np.isfinite(floor) and floor > 0:
        return float(floor)
    err = np.asarray(errors, float)
    positive = err[np.isfinite(err) & (err > 0)]
    return float(positive.min() / 10) if positive.size else 1e-16


def on_band(errors, floor: float) -> np.ndarray:
    """Errors at or below `floor` (0 included) moved into the band's middle; others kept."""
    err = np.asarray(errors, float)
    return np.where(err <= floor, floor * 10 ** (-BAND_DECADES / 2), err)


def draw_band(ax, floor: float, axis: str) -> None:
    """The labelled band [floor / 10^BAND_DECADES, floor] along `axis` ("x" or "y")."""
    low = floor * 10 ** -BAND_DECADES
    span = ax.axvspan if axis == "x" else ax.axhspan
    span(low, floor, color="#d0d0d0", lw=0, zorder=0)
    get, put = (ax.get_xlim, ax.set_xlim) if axis == "x" else (ax.get_ylim, ax.set_ylim)
    lo, hi = get()  # the band stays visible beside data that all sits on it
    put(min(lo, low), max(hi, floor * 10 ** BAND_DECADES))
    mid = floor * 10 ** (-BAND_DECADES / 2)
    if axis == "x":
        ax.text(mid, 0.5, FLOOR_LABEL, rotation=90, ha="center", va="center", fontsize=6.5,
                color="#555555", transform=ax.get_xaxis_transform())
    else:
        ax.text(0.5, mid, FLOOR_LABEL, ha="center", va="center", fontsize=6.5,
                color="#555555", transform=ax.get_yaxis_transform())


_SPARE: dict = {}  # count -> (figure, axes) saved and free to draw again (one process's)


def grid_figure(count: int):
    """(figure, flat list of `count` axes) laid out COLUMNS wide; spare axes removed.

    A figure of `count` axes that `save` wrote is drawn again, emptied, not made anew:
    creating the report's 636 axes and their ~11,000 tick objects took a fifth of its
    time; emptied axes keep their ticks, and their pixels are the same as new ones'."""
    if count in _SPARE:
        fig, axes = _SPARE.pop(count)
        for ax in axes:
            _empty(ax)
        # a new figure's margins until save() sets them: the band's limits are computed
        # through the axes' place on the figure (a last-bit difference moved a pixel)
        import matplotlib
        fig.subplots_adjust(**{k: matplotlib.rcParams["figure.subplot." + k] for k in
                               ("left", "right", "bottom", "top", "wspace", "hspace")})
        return fig, axes
    from matplotlib.figure import Figure
    cols = min(COLUMNS, count)
    rows = math.ceil(count / cols)
    fig = Figure(figsize=(PANEL[0] * cols, PANEL[1] * rows), dpi=DPI)
    canvas_class()(fig)
    flat = list(fig.subplots(rows, cols, squeeze=False).ravel())
    for ax in flat[count:]:
        fig.delaxes(ax)
    fig.refsim_spare = (count, flat[:count])
    return fig, flat[:count]


def _empty(ax) -> None:
    """The axes as new for the plots here: no artists, legend, labels or title, linear
    scales (their default locators and formatters), limits from the next data."""
    from matplotlib.transforms import Bbox
    for artist in [*ax.lines, *ax.patches, *ax.texts, *ax.collections, *ax.artists]:
        artist.remove()
    if ax.get_legend() is not None:
        ax.get_legend().remove()
    ax.set(title="", xlabel="", ylabel="", xscale="linear", yscale="linear")
    ax.dataLim = Bbox.null()  # as a new axes: no points, no smallest positive value
    ax.ignore_existing_data_limits = True
    ax.set_autoscale_on(True)
    ax.set_prop_cycle(None)


def _plain_log_labels(axis) -> None:
    """'1e-08' tick labels on a log axis: the default 10^k labels go through mathtext, which
    took a fifth of the report's rendering time. No minor ticks (2..9 x 10^k): unlabelled,
    ungridded, they were 19,500 tick objects and a third of the remaining drawing time of the
    22-case report; an axis spanning less than a decade keeps them, labelled ('2e-04'), as it
    has no decade to label. Call it after the data are drawn and the scale set (setting a
    scale resets the ticks)."""
    from matplotlib.ticker import LogFormatter, NullLocator
    if axis.get_scale() != "log":
        return
    axis.set_major_formatter(LogFormatter(labelOnlyBase=True))
    low, high = sorted(axis.get_view_interval())
    if high >= 10.0 * low:  # a decade or more: the labelled decades suffice
        axis.set_minor_locator(NullLocator())
    else:  # less than a decade: no decade inside, label the minor ticks instead
        axis.set_minor_formatter(LogFormatter(labelOnlyBase=False))


def _place_axis_labels(ax, renderer) -> None:
    """The axis labels where matplotlib puts them, labelpad beyond the tick labels' extent,
    from the labels' text and the font's metrics: matplotlib laid every tick label out once
    more per draw to find that extent (a tenth of the report's time)."""
    from matplotlib.ticker import NullLocator
    from matplotlib.transforms import IdentityTransform, blended_transform_factory
    shown = []  # (axis, its major or minor ticks, their locations in view)
    for axis, edge in ((ax.xaxis, ax.bbox.y0), (ax.yaxis, ax.bbox.x0)):
        reach = 0.0  # pixels from the axes' edge to the far side of its tick labels
        for ticks, ticker, where in ((axis.majorTicks, axis.major, axis.get_majorticklocs),
                                     (axis.minorTicks, axis.minor, axis.get_minorticklocs)):
            if isinstance(ticker.locator, NullLocator):
                continue
            locs = np.asarray(where(), float)  # the minor ones not on a major one
            labels = ticker.formatter.format_ticks(locs)  # all of them, as matplotlib
            low, high = axis.get_transform().transform(sorted(axis.get_view_interval()))
            at, slack = axis.get_transform().transform(locs), 1e-10 * (high - low)
            tick = ticks[0]
            shown.append((axis, ticks, locs[(at >= low - slack) & (at <= high + slack)]))
            prop = tick.label1.get_fontproperties()
            ascent, descent, _ = renderer._get_font_height_metrics(prop)
            if ascent is None:  # no font tables: matplotlib measures "lp"
                _, lp_h, descent = text_metrics(renderer, "lp", prop)
                ascent = lp_h - descent
            pad = renderer.points_to_pixels(tick.get_pad() + tick.get_tick_padding())
            reach = max(reach, renderer.points_to_pixels(tick.get_tick_padding()))
            for text in (t for t, x in zip(labels, at) if low - slack <= x <= high + slack):
                w, h, d = text_metrics(renderer, text, prop) if text else (0.0, 0.0, 0.0)
                reach = max(reach, pad + (w if axis is ax.yaxis else 0.0 if not text else
                                          max(h - d, ascent) + max(d, descent)))
        at = edge - reach - renderer.points_to_pixels(axis.labelpad)
        if axis is ax.xaxis:
            axis.set_label_coords(0.5, at, blended_transform_factory(ax.transAxes,
                                                                     IdentityTransform()))
        else:
            axis.set_label_coords(at, 0.5, blended_transform_factory(IdentityTransform(),
                                                                     ax.transAxes))
    return shown


def _whole_tick_lines(ax, shown) -> list:
    """Each axis's tick marks and gridlines as one line each (the ticks' own ones hidden):
    matplotlib drew two lines per tick through the axis's transform (7 % of the report's
    time). Returns what restores the axes after the draw."""
    from matplotlib.lines import Line2D
    undo = []
    for axis, ticks, locs in shown:
        tick, where = ticks[0], (ax.get_xaxis_transform if axis is ax.xaxis
                                 else ax.get_yaxis_transform)
        for name, which, ends in (("gridline", "grid", [0.0, 1.0, np.nan]),  # as a tick
                                  ("tick1line", "tick1", [0.0])):
            line = getattr(tick, name)
            if not line.get_visible() or not len(locs):
                continue
            kept = ax.__dict__.setdefault("refsim_tick_lines", {})  # made once per axes
            whole = kept.get((axis.axis_name, name, ticks is axis.majorTicks))
            if whole is None:
                whole = kept[axis.axis_name, name, ticks is axis.majorTicks] = Line2D([], [])
                whole.update_from(line)  # colour, width, style, marker, alpha
                whole.set(transform=where(which), clip_on=False, zorder=axis.get_zorder())
                whole.refsim_ticks = True  # not data: the legend's place ignores it
            along, across = np.repeat(locs, len(ends)), np.tile(ends, len(locs))
            whole.set_data((along, across) if axis is ax.xaxis else (across, along))
            ax.add_artist(whole)
            for t in ticks:
                getattr(t, name).set_visible(False)  # and the ticks made from ticks[0]
            undo += [whole.remove, lambda ticks=ticks, name=name: [
                getattr(t, name).set_visible(True) for t in ticks]]
    return undo


def finish_axes(ax, title: str, legend: bool = True) -> None:
    # y given: no automatic title position (matplotlib measured every tick label of the axes
    # to place it, a third of the drawing time; the x tick labels are below, nothing is above)
    ax.set_title(title, fontsize=8.5, y=1.0, pad=4.0)
    ax.grid(True, which="major", alpha=0.25)
    ax.tick_params(labelsize=7)
    _plain_log_labels(ax.xaxis)
    _plain_log_labels(ax.yaxis)
    handles, labels = ax.get_legend_handles_labels()
    if legend and handles:
        ax.add_artist(_legend_class()(ax, handles, labels, fontsize=6))


def save(fig, path: Path, title: str, left_in: float = 0.75, top_in: float = 0.65,
         colours: int = PALETTE_COLOURS) -> Path:
    """Suptitle, fixed margins (inches: `left_in` for the y labels, `top_in` for the title),
    and a palette PNG of `colours` colours at DPI (a fraction of an RGBA PNG's size)."""
    from PIL import Image
    fig.suptitle(title, fontsize=10)
    # fixed margins in inches (tight_layout would draw the whole figure once more: it doubled
    # the report's rendering time)
    width, height = fig.get_figwidth(), fig.get_figheight()
    if height < 0.5 + top_in + 0.5:  # at least half an inch of axes between the margins
        height = 0.5 + top_in + 0.5
        fig.set_figheight(height)
    fig.subplots_adjust(left=left_in / width, right=1 - 0.15 / width, bottom=0.5 / height,
                        top=1 - top_in / height, wspace=0.75 * COLUMNS / width * 1.0,
                        hspace=0.9 / PANEL[1])
    # drawn once on the Agg canvas and quantised from its pixels (savefig wrote an RGBA PNG
    # that was decoded again); zlib level 6, not optimize (level 9): 8x faster to write, the
    # PNG beside report.md 7 % larger; the HTML's WebP is the same pixels either way
    fig.set_dpi(DPI)
    canvas = fig.canvas if isinstance(fig.canvas, canvas_class()) else canvas_class()(fig)
    undo = [] if not hasattr(fig, "refsim_spare") else [
        step for ax in fig.axes
        for step in _whole_tick_lines(ax, _place_axis_labels(ax, canvas.get_renderer()))]
    canvas.draw()
    for step in undo:
        step()
    image = Image.frombuffer("RGBA", canvas.get_width_height(), canvas.buffer_rgba(), "raw",
                             "RGBA", 0, 1).convert("RGB").quantize(
        colours, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
    if hasattr(fig, "refsim_spare"):  # a grid_figure: drawn again by the next one
        _SPARE[fig.refsim_spare[0]] = (fig, fig.refsim_spare[1])
    else:
        _pyplot().close(fig)
    path.parent.mkdir(parents=True, exist_ok=True)
    image.save(path, format="PNG", compress_level=6)
    return path


@functools.cache
def _legend_class():
    """A frameless one-column legend placed and laid out as matplotlib's (loc="best": the
    first of its ten places that no line, vertex, band or text overlaps, else the least
    overlapped; its pads, handle length, spacing and baselines), drawn as a Line2D (line
    and a marker in its middle) and a Text per entry. Matplotlib's Legend built a packer,
    text area and drawing area per entry and laid them out three times per draw: a fifth
    of the report's time for 560 legends."""
    from matplotlib.artist import Artist
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch, Rectangle
    from matplotlib.text import Text
    from matplotlib.transforms import Bbox, IdentityTransform

    class CompactLegend(Artist):
        zorder = 5
        places = [None, "NE", "NW", "SW", "SE", "E", "W", "E", "S", "N", "C"]  # its codes

        def __init__(self, ax, handles, labels, fontsize):
            super().__init__()
            self.parent_axes, self.fontsize = ax, fontsize
            self.entries = [(Line2D([0, 0, 0], [0, 0, 0], color=h.get_color(),
                                    ls=h.get_linestyle(), lw=h.get_linewidth(),
                                    marker=h.get_marker(), ms=h.get_markersize(),
                                    mfc=h.get_markerfacecolor(), mec=h.get_markeredgecolor(),
                                    mew=h.get_markeredgewidth(), markevery=[1],
                                    transform=IdentityTransform()),
                             Text(0, 0, label, fontsize=fontsize, ha="left", va="baseline",
                                  transform=IdentityTransform()))
                            for h, label in zip(handles, labels)]
            for artist in (a for pair in self.entries for a in pair):
                artist.set_figure(ax.get_figure(root=False))

        def draw(self, renderer):
            em = renderer.points_to_pixels(self.fontsize)
            prop = self.entries[0][1].get_fontproperties()
            _, lp_h, lp_d = text_metrics(renderer, "lp", prop)
            ascent, descent, _ = renderer._get_font_height_metrics(prop)  # a line's least
            if ascent is None:
                ascent, descent = lp_h - lp_d, lp_d
            rows = []  # (label width, height above the baseline, depth below it)
            for _, text in self.entries:
                w, h, d = text_metrics(renderer, text.get_text(), prop)
                rows.append((w, max(lp_h - lp_d, h - d, ascent, 0.7 * em), max(d, descent)))
            width = max(w for w, _, _ in rows) + 2.8 * em + 0.8 * em  # handle, pad, borders
            height = sum(a + d for _, a, d in rows) + 0.5 * em * (len(rows) - 1) + 0.8 * em
            left, bottom = self._best(width, height, 0.5 * em, renderer)
            self.box = Bbox.from_bounds(left, bottom, width, height)  # where it was drawn
            top = bottom + height - 0.4 * em
            for (line, text), (_, above, depth) in zip(self.entries, rows):
                base, x = top - above, left + 0.4 * em
                line.set_data([x, x + em, x + 2 * em], [base + 0.35 * em] * 3)
                text.set_position((x + 2.8 * em, base))
                line.draw(renderer)
                text.draw(renderer)
                top = base - depth - 0.5 * em

        def _best(self, width, height, pad, renderer):
            ax = self.parent_axes
            lines = [a.get_transform().transform_path(a.get_path()) for a in ax.lines
                     if not hasattr(a, "refsim_ticks")]
            lines += [a.get_transform().transform_path(a.get_path()) for a in ax.patches
                      if isinstance(a, Patch) and not isinstance(a, Rectangle)]
            boxes = [a.get_bbox().transformed(a.get_data_transform()) for a in ax.patches
                     if isinstance(a, Rectangle)]
            boxes += [a.get_window_extent(renderer) for a in ax.texts]
            inside = ax.bbox.padded(-pad, -pad)
            tried = []
            for code in range(1, 11):
                at = Bbox.from_bounds(0, 0, width, height).anchored(self.places[code], inside)
                box = Bbox.from_bounds(*at.p0, width, height)
                badness = (sum(box.count_contains(p.vertices) for p in lines)
                           + box.count_overlaps(boxes)
                           + sum(p.intersects_bbox(box, filled=False) for p in lines))
                if badness == 0:
                    return at.p0
                tried.append((badness, code, tuple(at.p0)))
            return min(tried)[2]

    return CompactLegend
