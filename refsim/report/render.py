"""The report's blocks rendered twice: Markdown (figures as files beside it) and one
self-contained HTML page (figures inlined as base64 lossless WebP, no external reference;
no whitespace between table tags: the default run's report fits 2 MB).

Blocks: ("h1"|"h3", text), ("h2", text[, anchor]), ("p", text with `code` and **bold**),
("table", DataFrame), ("img", path, alt text[, its WebP bytes]), ("nav",) where the HTML's
table of contents goes (the Markdown leaves it out); ("html", markup) for the HTML only,
("md_img", path, alt) for the Markdown only (the HTML's coloured table stands for that
figure), ("details", summary, DataFrame): a table folded in the HTML, plain in the Markdown.

The figures' pixels come from `canvas_class()`: matplotlib's Agg canvas drawing each text it
drew before from a stored coverage mask (refsim.report.style draws every figure on it).
"""
from __future__ import annotations

import base64
import functools
import html
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd


def _md_table(df: pd.DataFrame) -> str:
    cells = [[str(c).replace("|", "\\|") for c in df.columns]]
    cells += [[str(v).replace("|", "\\|") for v in row] for row in df.itertuples(index=False)]
    lines = ["| " + " | ".join(r) + " |" for r in cells]
    lines.insert(1, "|" + "|".join("---" for _ in df.columns) + "|")
    return "\n".join(lines)


def render_markdown(blocks, out: Path) -> str:
    parts = []
    for block in blocks:
        kind = block[0]
        if kind in ("h1", "h2", "h3"):
            parts.append("#" * int(kind[1]) + " " + block[1])
        elif kind == "p":
            parts.append(block[1])
        elif kind == "table":
            parts.append(_md_table(block[1]))
        elif kind == "details":
            parts.append(f"{block[1]}:\n\n{_md_table(block[2])}")
        elif kind in ("img", "md_img"):
            parts.append(f"![{block[2]}]({Path(block[1]).relative_to(out).as_posix()})")
    return "\n\n".join(parts) + "\n"


CSS = """body{font-family:system-ui,sans-serif;max-width:1300px;margin:2em auto;padding:0 1em;
color:#222}h1{font-size:1.5em}h2{border-top:1px solid #ccc;padding-top:.8em;margin-top:2em}
table{border-collapse:collapse;font-size:.8em;margin:.5em 0}td,th{border:1px solid #ddd;
padding:2px 6px;text-align:right}th{background:#f3f3f3}td:nth-child(-n+2){text-align:left}
img{max-width:100%;display:block;margin:.4em 0}nav a{margin-right:1em}code{background:#f5f5f5}
td.v-reaches,td.v-matches{background:#d9f2d9}td.v-does,td.v-below{background:#f8d0d0}td.v-unresolved{background:#fde9b8}
td.v-unsupported,td.v-not{background:#e6e6e6}
table.board,table.legend{font-size:13px}table.board td.sb,table.legend td.sb{text-align:center;
line-height:1.3;padding:3px 6px;white-space:nowrap}table.board th.group{text-align:left;
background:#e9eef5;font-size:13px}table.board td.case{text-align:left;white-space:nowrap}"""


def _inline(text: str) -> str:
    """Markdown's `code` and **bold** in a paragraph, escaped for HTML."""
    out = html.escape(text)
    for mark, tag in (("**", "b"), ("`", "code")):
        pieces = out.split(mark)
        out = "".join(f"<{tag}>{s}</{tag}>" if k % 2 else s for k, s in enumerate(pieces))
    return out


def _table_html(df: pd.DataFrame) -> str:
    """A table; the cells of a `verdict` or `target` column carry a class named by their
    first word (v-reaches, v-does, v-matches, v-below, ...) for colour."""
    page = re.sub(r">\s+<", "><", df.to_html(index=False, border=0, escape=True))
    column = next((c for c in ("verdict", "target") if c in df), None)
    if column is None:
        return page
    for verdict in df[column].unique():
        css = "v-" + str(verdict).split(" ")[0]
        page = page.replace(f"<td>{html.escape(str(verdict))}</td>",
                            f'<td class="{css}">{html.escape(str(verdict))}</td>')
    return page


def _block_html(block, toc: list) -> str:
    kind = block[0]
    if kind == "h2":
        anchor = block[2] if len(block) > 2 else f"s{len(toc)}"
        toc.append(f'<a href="#{anchor}">{html.escape(block[1])}</a>')
        return f'<h2 id="{anchor}">{html.escape(block[1])}</h2>'
    if kind in ("h1", "h3"):
        return f"<{kind}>{html.escape(block[1])}</{kind}>"
    if kind == "p":
        return f"<p>{_inline(block[1])}</p>"
    if kind == "table":
        return _table_html(block[1])
    if kind == "html":
        return block[1]
    if kind == "details":
        return (f"<details><summary>{html.escape(block[1])}</summary>"
                f"{_table_html(block[2])}</details>")
    if kind == "img":
        data = base64.b64encode(block[3] if len(block) > 3 else webp(block[1])).decode()
        return f'<img alt="{html.escape(block[2])}" src="data:image/webp;base64,{data}">'
    return ""


def webp(png) -> bytes:
    """The figure as lossless WebP (the same pixels, a fifth smaller than the palette PNG:
    1.38 MB of PNG -> 1.10 MB on a default run; every current browser decodes it)."""
    import io
    from PIL import Image
    buffer = io.BytesIO()
    Image.open(png).save(buffer, "WEBP", lossless=True, method=4)
    return buffer.getvalue()


def render_html(blocks, manifest) -> str:
    body, toc, nav_at = [], [], None
    for block in blocks:
        if block[0] == "nav":
            nav_at = len(body)
            continue
        body.append(_block_html(block, toc))
    nav = f"<nav>{''.join(toc)}</nav>" if toc else ""
    body.insert(min(len(body), 6) if nav_at is None else nav_at, nav)
    title = html.escape(f"refsim report {manifest.get('run_id', '')}")
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{title}</title>"
            f"<style>{CSS}</style></head><body>{''.join(body)}</body></html>\n")


_MASKS: dict = {}  # (text, font, angle, dpi, antialiased) -> (coverage, left, bottom)
_MASKS_MAX = 20000


_METRICS: dict = {}  # (text, font, dpi) -> (width, height, descent) in pixels
_HEIGHTS: dict = {}  # (font, dpi) -> (ascent, descent, line gap) from its tables


def _font_key(prop) -> tuple:
    return (tuple(prop.get_family()), prop.get_style(), prop.get_variant(), prop.get_weight(),
            prop.get_stretch(), prop.get_size_in_points(), prop.get_file())


def text_metrics(renderer, s: str, prop) -> tuple:
    """Agg's (width, height, descent) of plain text `s`, measured once per font and dpi."""
    key = (s, _font_key(prop), renderer.dpi)
    if key not in _METRICS:
        if len(_METRICS) >= _MASKS_MAX:
            _METRICS.clear()
        _METRICS[key] = renderer.get_text_width_height_descent(s, prop, ismath=False)
    return _METRICS[key]


@functools.cache
def canvas_class():
    """An Agg canvas whose renderer draws a text it drew before from a stored coverage mask.

    Agg lays a text out and renders it glyph by glyph at every draw: a fifth of the report's
    time for ~10,000 texts, most of them the same tick labels, legend entries and axis labels
    again. A text is rendered once, at a whole-pixel origin, onto a transparent canvas of its
    own; its alpha is its coverage, which draw_text_image blends in the text's colour as Agg
    blends each glyph (overlapping glyphs combine alike). The text's origin is rounded to the
    pixel (up to half a pixel off its unrounded place, as matplotlib before 3.8 drew it)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg, RendererAgg

    class TextMaskRenderer(RendererAgg):
        def _get_font_height_metrics(self, prop):
            """(ascent, descent, line gap) of the font's tables, as matplotlib's Text
            layout (3.11) reads them for every text it lays out when a renderer has no
            such method: looked up once per font and dpi here."""
            key = (_font_key(prop), self.dpi)
            if key not in _HEIGHTS:
                from matplotlib.font_manager import findfont, get_font
                font, _HEIGHTS[key] = get_font(findfont(prop)), (None, None, None)
                for name, gap, up, down in (("OS/2", "sTypoLineGap", "sTypoAscender",
                                             "sTypoDescender"),
                                            ("hhea", "lineGap", "ascent", "descent")):
                    table = font.get_sfnt_table(name)
                    if table is not None:  # matplotlib's arithmetic, in its order
                        scale = (1 / font.get_sfnt_table("head")["unitsPerEm"]
                                 * prop.get_size_in_points() * self.dpi / 72)
                        _HEIGHTS[key] = (table[up] * scale, -table[down] * scale,
                                         table[gap] * scale)
                        break
            return _HEIGHTS[key]

        def draw_text(self, gc, x, y, s, prop, angle, ismath=False, mtext=None):
            if ismath:
                return super().draw_text(gc, x, y, s, prop, angle, ismath, mtext)
            key = (s, _font_key(prop), angle, self.dpi, bool(gc.get_antialiased()),
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
        w, h, d = text_metrics(renderer, s, prop)
        slack = 4 + math.ceil(renderer.points_to_pixels(prop.get_size_in_points()))
        along, across = math.ceil(w) + slack, math.ceil(h + d) + slack  # the ink's reach
        rx, ry = ((along, across) if angle % 180 == 0 else (across, along) if angle % 90 == 0
                  else (math.ceil(math.hypot(w, h + d)) + slack,) * 2)
        own = RendererAgg(2 * rx + 1, 2 * ry + 1, renderer.dpi)
        black = own.new_gc()
        black.set_antialiased(gc.get_antialiased())
        RendererAgg.draw_text(own, black, rx, ry, s, prop, angle, False, mtext)
        alpha = np.asarray(own.buffer_rgba())[:, :, 3]
        rows, cols = np.flatnonzero(alpha.any(axis=1)), np.flatnonzero(alpha.any(axis=0))
        if not rows.size:
            return np.zeros((0, 0), np.uint8), 0, 0
        coverage = np.ascontiguousarray(alpha[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1])
        return coverage, int(cols[0]) - rx, int(rows[-1]) + 1 - ry

    class TextMaskCanvas(FigureCanvasAgg):
        def get_renderer(self, *args, **kwargs):
            renderer = super().get_renderer(*args, **kwargs)
            if not isinstance(renderer, TextMaskRenderer):  # made anew for this size
                renderer = self.renderer = TextMaskRenderer(renderer.width, renderer.height,
                                                            renderer.dpi)
            return renderer

    return TextMaskCanvas
