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
    _canvas_class()(fig)
    flat = list(fig.subplots(rows, cols, squeeze=False).ravel())
    for ax in flat[count:]:
        fig.delaxes(ax)
    fig.refsim_spare = (count, flat[:count])
    return fig, flat[:count]


def _empty(ax) -> None:
    """The axes as new for the plots here: no artists, legend, labels or title, linear
    scales (their default locators and formatters), limits from the next data."""
    from matplotlib.transforms import Bbox
    for artist in [*ax.lines, *ax.patches, *ax.texts, *ax.collections]:
        artist.remove()
    if ax.get_legend() is not None:
        ax.get_legend().remove()
    ax.set_title("")
    ax.set_xlabel("")
    ax.set_ylabel("")
    ax.set_xscale("linear")
    ax.set_yscale("linear")
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


def finish_axes(ax, title: str, legend: bool = True) -> None:
    # y given: no automatic title position (matplotlib measured every tick label of the axes
    # to place it, a third of the drawing time; the x tick labels are below, nothing is above)
    ax.set_title(title, fontsize=8.5, y=1.0, pad=4.0)
    ax.grid(True, which="major", alpha=0.25)
    ax.tick_params(labelsize=7)
    _plain_log_labels(ax.xaxis)
    _plain_log_labels(ax.yaxis)
    if legend and ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=6, frameon=False, loc="best")


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
    canvas = fig.canvas if isinstance(fig.canvas, _canvas_class()) else _canvas_class()(fig)
    canvas.draw()
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


_MASKS: dict = {}  # (text, font, angle, dpi, antialiased) -> (coverage, left, bottom)
_MASKS_MAX = 20000


@functools.cache
def _canvas_class():
    """An Agg canvas whose renderer draws a text it drew before from a stored coverage mask.

    Agg lays a text out and renders it glyph by glyph at every draw: a fifth of the report's
    time for ~10,000 texts, most of them the same tick labels, legend entries and axis labels
    again. A text is rendered once, at a whole-pixel origin, onto a transparent canvas of its
    own; its alpha is its coverage, which draw_text_image blends in the text's colour as Agg
    blends each glyph (overlapping glyphs combine alike). The text's origin is rounded to the
    pixel (up to half a pixel off its unrounded place, as matplotlib before 3.8 drew it)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg, RendererAgg

    class TextMaskRenderer(RendererAgg):
        def draw_text(self, gc, x, y, s, prop, angle, ismath=False, mtext=None):
            if ismath:
                return super().draw_text(gc, x, y, s, prop, angle, ismath, mtext)
            key = (s, tuple(prop.get_family()), prop.get_style(), prop.get_variant(),
                   prop.get_weight(), prop.get_stretch(), prop.get_size_in_points(),
                   prop.get_file(), angle, self.dpi, bool(gc.get_antialiased()),
                   *(str(getattr(mtext, g)()) for g in ("get_fontfeatures", "get_language")
                     if hasattr(mtext, g)))
            mask = _MASKS.get(key)
            if mask is None:
                if len(_MASKS) >= _MASKS_MAX:
                    _MASKS.clear()
                mask = _MASKS[key] = _coverage(self, gc, s, prop, angle, mtext)
            coverage, left, bottom = mask
            if coverage.size:  # y is downwards; draw_text_image's y is the mask's bottom
                self._renderer.draw_text_image(coverage, round(x) + left, round(y) + bottom,
                                               0, gc)

    def _coverage(renderer, gc, s, prop, angle, mtext):
        """(uint8 coverage, left, bottom) of `s` drawn at a whole-pixel origin."""
        w, h, d = renderer.get_text_width_height_descent(s, prop, ismath=False)
        reach = math.ceil(math.hypot(w, h + d)) + 4 + math.ceil(
            renderer.points_to_pixels(prop.get_size_in_points()))  # ink's reach, with slack
        own = RendererAgg(2 * reach + 1, 2 * reach + 1, renderer.dpi)
        black = own.new_gc()
        black.set_antialiased(gc.get_antialiased())
        RendererAgg.draw_text(own, black, reach, reach, s, prop, angle, False, mtext)
        alpha = np.asarray(own.buffer_rgba())[:, :, 3]
        rows, cols = np.flatnonzero(alpha.any(axis=1)), np.flatnonzero(alpha.any(axis=0))
        if not rows.size:
            return np.zeros((0, 0), np.uint8), 0, 0
        coverage = np.ascontiguousarray(alpha[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1])
        return coverage, int(cols[0]) - reach, int(rows[-1]) + 1 - reach

    class TextMaskCanvas(FigureCanvasAgg):
        def get_renderer(self, *args, **kwargs):
            renderer = super().get_renderer(*args, **kwargs)
            if not isinstance(renderer, TextMaskRenderer):  # made anew for this size
                renderer = self.renderer = TextMaskRenderer(renderer.width, renderer.height,
                                                            renderer.dpi)
            return renderer

    return TextMaskCanvas
