"""The report's blocks rendered twice: Markdown (figures as files beside it) and one
self-contained HTML page (figures inlined as base64 lossless WebP, no external reference;
no whitespace between table tags: the default run's report fits 2 MB).

Blocks: ("h1"|"h3", text), ("h2", text[, anchor]), ("p", text with `code` and **bold**),
("table", DataFrame), ("img", path, alt text), ("nav",) where the HTML's table of contents
goes (the Markdown leaves it out); ("html", markup) for the HTML only, ("md_img", path, alt)
for the Markdown only (the HTML's coloured table stands for that figure), ("details",
summary, DataFrame): a table folded in the HTML, plain in the Markdown.
"""
from __future__ import annotations

import base64
import html
import re
from pathlib import Path

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
        data = base64.b64encode(_webp(Path(block[1]))).decode()
        return f'<img alt="{html.escape(block[2])}" src="data:image/webp;base64,{data}">'
    return ""


def _webp(png: Path) -> bytes:
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
