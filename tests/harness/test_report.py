"""`refsim report`: built from a real stored run; tables, figures, recommendation, Pareto
front, and the page as a browser draws it (headless Chromium, where installed)."""
import html
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from refsim.run import runner
from refsim.report.build import recommendation, write_report
from refsim.report.plots import pareto_front
from refsim.store.results import RunStore, load_results, new_run_id


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """free_fall and stiff_spring on refsim and pymunk, three integrators, the dt sweep."""
    jobs = runner.expand(cases=["free_fall", "stiff_spring"], engines=["refsim", "pymunk"],
                         integrators=["symplectic_euler_dk", "rk4", "velocity_verlet"],
                         variants=["default"])
    root = tmp_path_factory.mktemp("runs")
    st = RunStore.create(root, {"run_id": new_run_id(), "command": "test", "engines": {}})
    runner.run_matrix(jobs, st, repeats=1)
    write_report(st.dir)
    return st.dir


def test_pareto_front_keeps_only_undominated_points():
    err = np.array([1e-2, 1e-4, 1e-4, 1e-6, 1e-3])
    cost = np.array([1.0, 2.0, 5.0, 10.0, 3.0])
    # (1e-3, 3) is beaten by (1e-4, 2); (1e-4, 5) by (1e-4, 2)
    assert list(pareto_front(err, cost)) == [3, 1, 0]


def test_a_text_drawn_from_its_stored_mask_is_the_text_agg_draws():
    """refsim.report.render's canvas draws a text it drew before from its stored coverage.
    At a whole-pixel origin (where it puts every text) the pixels are Agg's own, at the first
    draw and from the stored masks at the second; the same words at another angle, size or
    colour are their own text."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from refsim.report.render import canvas_class

    def pixels(canvas_class):
        fig = Figure(figsize=(3, 2), dpi=72)  # 216 x 144 pixels
        canvas = canvas_class(fig)
        for x, y, size, angle, colour in [(5, 15, 7, 0, "k"), (5, 45, 8.5, 0, "#d62728"),
                                          (200, 5, 7, 90, "#1f77b4"), (5, 110, 10, 0, "k")]:
            fig.text(x, y, "1e-08 rk4 (p=4.00) ff", fontsize=size, rotation=angle, va="baseline",
                     rotation_mode="anchor", color=colour, transform=None)  # origin (x, y) px
        return [(canvas.draw(), np.asarray(canvas.buffer_rgba()).copy())[1] for _ in "12"]

    (agg, _), (first, again) = pixels(FigureCanvasAgg), pixels(canvas_class())
    assert (agg[:, :, :3] < 128).any(axis=2).sum() > 300  # the texts are there
    # one level at most, where glyphs overlap: Agg blends each glyph's 8-bit coverage into
    # the pixel in turn, the mask holds their union rounded to 8 bits once (2 of 31,104
    # pixels here); a wrong place, angle or size is tens of levels over many pixels
    assert np.abs(first.astype(int) - agg).max() <= 1
    np.testing.assert_array_equal(again, first)  # drawn from the stored masks


@pytest.mark.parametrize("lines", [  # (y(x), plot keywords)
    # two lines crossing over the top: the legend goes below them
    [(lambda x: 0.5 + 0.5 * x, dict(color="r", marker="s", ls="--", label="rk4 (p=4)")),
     (lambda x: 1 - 0.5 * x, dict(marker="o", mfc="none", label="midpoint"))],
    [(lambda x: 1 - 4 * (x - 0.5) ** 2, dict(marker="D", label="arch"))],  # both top corners free
    # a Pareto step (its handle a plain line) and a dotted line
    [(lambda x: x, dict(color="k", marker="o", ms=3, lw=1.4, drawstyle="steps-post",
                        label="all engines")), (lambda x: x * x, dict(marker="^", ls=":"))],
    # eight waves, markers every third point: nowhere free, the least overlapped place taken
    [(lambda x, k=k: np.sin(6 * x + k), dict(marker="o", ls="-.", markevery=3, label=f"{k}"))
     for k in range(8)]])
def test_the_compact_legend_is_matplotlibs_legend(lines):
    """refsim.report.style's legend (a line and a text per entry) draws the pixels of
    matplotlib's Legend(fontsize=6, frameon=False, loc="best") over the same lines: the same
    place, pads, spacing, handles and labels."""
    from refsim.report import style
    drawn = []
    for ours in (True, False):
        style._SPARE.clear()
        fig, (ax,) = style.grid_figure(1)
        x = np.linspace(0.0, 1.0, 20)
        for y, kwargs in lines:
            ax.plot(x, y(x), **{"label": "b", **kwargs})
        style.finish_axes(ax, "legend", legend=ours)
        if not ours:
            ax.legend(fontsize=6, frameon=False, loc="best")
        fig.canvas.draw()
        drawn.append(np.asarray(fig.canvas.buffer_rgba()).copy())
        assert (len(ax.artists), ax.get_legend() is None) == ((1, True) if ours else (0, False))
    np.testing.assert_array_equal(drawn[0], drawn[1])


def test_axis_labels_and_tick_lines_are_matplotlibs():
    """save() places each axis label from its tick labels' text and the font's metrics
    (refsim.report.style._place_axis_labels) where matplotlib's automatic placement (every
    tick label laid out) puts it, and draws the tick marks and gridlines of an axis as one
    line: log axes over decades and within one (labelled minor ticks, another font size),
    linear axes with wide and narrow labels."""
    from refsim.report import style
    style._SPARE.clear()
    fig, axes = style.grid_figure(4)
    x = np.linspace(1.0, 2.0, 9)
    for ax, (xs, ys, xscale, yscale) in zip(axes, [
            (x, 1e-12 * x ** 30, "log", "log"), (x * 1e-3, 1 + 0.5 * x, "log", "log"),
            (x, -0.0025 * x, "linear", "linear"), (x * 1e4, x * 3, "linear", "log")]):
        ax.plot(xs, ys, marker="o", label="a")
        ax.set(xscale=xscale, yscale=yscale, xlabel="x label", ylabel="y label")
        style.finish_axes(ax, "title")
    fig.subplots_adjust(left=0.1, bottom=0.2, wspace=0.6)

    def label_places():
        fig.canvas.draw()
        return [a.get_window_extent().bounds for ax in axes for a in (ax.xaxis.label,
                                                                      ax.yaxis.label)]

    pixels = lambda: np.asarray(fig.canvas.buffer_rgba()).astype(int)  # noqa: E731
    automatic, per_tick = label_places(), pixels()
    undo = [step for ax in axes for step in style._whole_tick_lines(
        ax, style._place_axis_labels(ax, fig.canvas.get_renderer()))]
    # the same sums in another order: within a millionth of a pixel
    np.testing.assert_allclose(label_places(), automatic, rtol=0, atol=1e-6)
    # tick marks and gridlines drawn as a line per axis: matplotlib's per tick lines' pixels
    # but where a gridline ends under a spine, within 3 levels (its 181-point path, which
    # path.simplify shortens, ends a fraction of a pixel off the 2-point one)
    moved = np.argwhere(np.abs(pixels() - per_tick).max(axis=2) > 0)  # (row, column)
    assert np.abs(pixels() - per_tick).max() <= 3 and len(undo) >= 8
    rows = [fig.bbox.height - e for a in axes for e in (a.bbox.y0, a.bbox.y1)]
    columns = [e for a in axes for e in (a.bbox.x0, a.bbox.x1)]
    near = lambda v, lines: min(abs(v - e) for e in lines) <= 1  # noqa: E731
    assert all(near(r, rows) or near(c, columns) for r, c in moved)
    for step in undo:
        step()
    np.testing.assert_array_equal((fig.canvas.draw(), pixels())[1], per_tick)  # as before
    # the y labels stand at different distances from their axes (tick labels' widths)
    assert len({round(ax.bbox.x0 - b[0]) for ax, b in zip(axes, automatic[1::2])}) > 2


def test_a_figure_drawn_again_is_the_figure_drawn_new(run_dir, tmp_path):
    """A grid figure save() wrote is emptied and drawn again (refsim.report.style): each
    case's convergence figure drawn into the other case's figure has the pixels it has
    drawn into a new one (no line, band, label, limit or scale of the other's left)."""
    from PIL import Image
    from refsim.report import plots, style
    table = load_results(run_dir)
    table = table[np.isfinite(table["dt"])]
    draw = lambda case: np.asarray(Image.open(plots.convergence(  # noqa: E731
        table[table["case"] == case], "err_max", "m", tmp_path / "f.png", case,
        style.Style.of_table(table))).convert("RGB"))
    new = {}
    for case in ("free_fall", "stiff_spring"):
        style._SPARE.clear()
        new[case] = draw(case)
    (count, (fig, _)), = style._SPARE.items()
    assert not np.array_equal(new["free_fall"], new["stiff_spring"])
    for case in ("free_fall", "stiff_spring"):  # free_fall's limits are the wider
        np.testing.assert_array_equal(draw(case), new[case])
    assert style._SPARE[count][0] is fig  # the one figure, drawn again twice


def test_markdown_has_every_case_tables_figures_and_orders(run_dir):
    md = (run_dir / "report.md").read_text()
    for section in ("## free_fall / default", "## stiff_spring / default"):
        assert section in md
    assert "### Measured against nominal order" in md and "| rk4 |" in md
    images = re.findall(r"!\[[^]]*\]\(([^)]+)\)", md)
    kinds = {Path(i).stem.rsplit("-", 1)[-1] for i in images}
    assert kinds == {"overview", "work", "conv", "energy"}
    from PIL import Image
    for image in images:
        data = (run_dir / image).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 2_000
        with Image.open(run_dir / image) as png:  # a real figure, drawn with its palette
            assert min(png.size) >= 100 and png.mode == "P"
    # pymunk's kick-drift Euler on the spring measures first order in the order table
    row = next(line for line in md.splitlines() if line.startswith("| pymunk |")
               and "symplectic_euler_dk" in line)
    measured = float(row.split("|")[4])
    assert abs(measured - 1.0) < 0.15


def test_overview_comes_before_the_case_sections(run_dir):
    md = (run_dir / "report.md").read_text()
    overview = md.index("## Overview")
    assert overview < md.index("## free_fall / default")
    assert "plots/overview.png" in md[overview:md.index("## free_fall / default")]
    scoreboard = [line for line in md.splitlines()
                  if line.startswith("| particles | free_fall / default |")]
    assert [line.split("|")[3].strip() for line in scoreboard] == ["refsim", "pymunk"]
    # rk4 and velocity Verlet are exact on free fall, pymunk's drift-kick errs g t dt: both
    # consistent with their methods, only refsim reaches the target
    assert [line.split("|")[4].strip().split(" (")[0] for line in scoreboard] == [
        "reaches the target", "does not reach the target"]
    assert all(line.split("|")[8].strip().endswith(" consistent") for line in scoreboard)
    # one line per engine first, in the run's words
    for engine in ("refsim", "pymunk"):
        assert re.search(rf"\*\*{engine}\*\*: \d of 2 case variants it runs reach the "
                         r"target; \d+ of \d+ judged rows consistent", md)
    page = (run_dir / "report.html").read_text()
    assert page.index('id="overview"') < page.index("free_fall / default</h2>")
    # grouped by model group: the group's heading row comes before its cases' rows
    assert page.index("model group particles</th>") < page.index(
        '<td class="case">free_fall / default</td>')


def test_html_is_self_contained(run_dir):
    page = (run_dir / "report.html").read_text()
    assert page.startswith("<!DOCTYPE html>")
    sources = re.findall(r'src="([^"]+)"', page)
    assert sources and all(s.startswith("data:image/webp;base64,") for s in sources)
    assert "http://" not in page and "https://" not in page
    assert page.count("<table") >= 4


def _configurations():
    """Five hand-made rows: (engine, integrator, dt, status, err_max, step_s, us_per_step)."""
    rows = [("refsim", "rk4", 0.01, "ok", 1e-6, 0.30, 30.0),
            ("refsim", "velocity_verlet", 0.01, "ok", 1e-3, 0.05, 5.0),
            ("pymunk", "symplectic_euler_dk", 0.001, "ok", 1e-5, 0.20, 2.0),
            ("refsim", "rk4", 0.001, "diverged", 1e-9, 0.01, 1.0),  # cheapest, but not ok
            ("refsim", "rk4", 0.005, "ok", np.nan, 0.02, 4.0)]  # cheaper still, but no error
    return pd.DataFrame(rows, columns=["engine", "integrator", "dt", "status", "err_max",
                                       "step_s", "us_per_step"]).assign(engine_variant="")


@pytest.mark.parametrize("target, expected", [
    (1e-5, "**pymunk symplectic_euler_dk at dt = 0.001 s**: 1e-05 m in 0.2 s (2 us/step; 2 of 3 "
           "configurations reach the target)."),
    (1e-2, "**refsim velocity_verlet at dt = 0.01 s**: 0.001 m in 0.05 s (5 us/step; 3 of 3 "
           "configurations reach the target)."),
    (1e-6, "**refsim rk4 at dt = 0.01 s**: 1e-06 m in 0.3 s (30 us/step; 1 of 3 "
           "configurations reach the target).")])
def test_recommendation_is_the_cheapest_finished_row_reaching_the_target(target, expected):
    """Read off the table by hand: among the finished rows (status ok, finite error) whose
    error meets the target, the least stepping time; a diverged row or one without an error
    is never recommended however cheap."""
    text = recommendation(_configurations(), "err_max", "m", target)
    assert text.endswith(expected), text


def test_recommendation_names_the_most_accurate_when_none_reaches_the_target(run_dir):
    text = recommendation(_configurations(), "err_max", "m", 1e-8)
    assert "none reaches the target err_max <= 1e-08 m" in text
    assert "the most accurate is refsim rk4 at dt = 0.01 s with 1e-06 in 0.3 s" in text
    stored = load_results(run_dir)
    assert "none reaches" in recommendation(stored[stored["case"] == "stiff_spring"],
                                            "err_max", "m", 1e-30)


def test_cli_report_bad_input_is_one_line(tmp_path):
    out = subprocess.run([sys.executable, "-m", "refsim", "report", str(tmp_path)],
                         capture_output=True, text=True)
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1
    assert "RUN_DIR must be a stored run" in out.stderr


BROWSER = shutil.which("chromium-headless-shell") or shutil.which("chromium")
CHECK = """<script>
window.__errors = [];
window.addEventListener("error", e => window.__errors.push(String(e.message || e.target.src
  || e.type)), true);
const consoleError = console.error;
console.error = (...args) => { window.__errors.push(args.join(" ")); consoleError(...args); };
window.addEventListener("load", () => {
  const images = Array.from(document.images);
  const box = document.getElementById("overview").getBoundingClientRect();
  const result = {images: images.length,
                  loaded: images.filter(i => i.complete && i.naturalWidth > 0).length,
                  errors: window.__errors, overviewTop: box.top, overviewHeight: box.height,
                  viewport: window.innerHeight};
  const out = document.createElement("pre");
  out.id = "refsim-check";
  out.textContent = JSON.stringify(result);
  document.body.appendChild(out);
});
</script>"""


@pytest.fixture
def browser():
    """Headless Chromium; under CI (CI=true) its absence fails the test instead of skipping:
    .ci/run installs Debian's chromium-headless-shell."""
    if BROWSER is None:
        message = "no Chromium on this machine (apt-get install chromium-headless-shell)"
        if os.environ.get("CI") == "true":
            pytest.fail(message + "; CI must check the page in a browser")
        pytest.skip(message)
    return BROWSER


def _dump_dom(browser, page: Path) -> str:
    return subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu",
                           "--window-size=1200,1600", "--virtual-time-budget=10000",
                           "--dump-dom", page.as_uri()],
                          capture_output=True, text=True, timeout=120, check=True).stdout


def test_report_renders_in_headless_chromium(browser, run_dir, tmp_path):
    """The browser draws the page: a screenshot of real size whose pixels are not blank; in
    the page as loaded every embedded figure decoded, no error reached the console, and the
    overview sits in the first screens of the page."""
    shot = tmp_path / "shot.png"
    page = (run_dir / "report.html").read_text()
    args = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
            f"--screenshot={shot}", "--window-size=1200,1600", (run_dir / "report.html").as_uri()]
    subprocess.run(args, capture_output=True, timeout=120, check=True)
    import matplotlib.image as mpimg
    pixels = mpimg.imread(shot)
    assert pixels.shape[:2] == (1600, 1200)
    assert pixels[..., :3].std() > 0.05  # text and figures, not a blank page
    checked = tmp_path / "checked.html"
    checked.write_text(page.replace("<head>", "<head>" + CHECK, 1))
    found = re.search(r'<pre id="refsim-check">([^<]*)</pre>', _dump_dom(browser, checked))
    assert found, "the check script did not run"
    result = json.loads(html.unescape(found.group(1)))
    assert result["images"] == page.count("<img") and result["images"] >= 4
    assert result["loaded"] == result["images"]
    assert result["errors"] == []
    assert result["overviewHeight"] > 0 and 0 <= result["overviewTop"] < 2 * result["viewport"]


def test_results_merged_by_hand_with_empty_missing_values_still_report(run_dir, tmp_path):
    """A results.csv re-written by pandas (missing numbers as "", not refsim's "nan"), as when
    two runs are merged by hand: numbers stay numbers, text stays text, the report is written
    (it crashed with a TypeError before)."""
    import pandas as pd
    from refsim.report.build import write_report
    from refsim.store.results import load_results
    merged = tmp_path / "merged"
    merged.mkdir()
    for name in ("manifest.json", "series.jsonl"):
        (merged / name).write_bytes((run_dir / name).read_bytes())
    original = load_results(run_dir)
    original.to_csv(merged / "results.csv", index=False)  # NaN written as ""
    assert ",," in (merged / "results.csv").read_text()
    table = load_results(merged)
    for col in ("err_rms", "energy_drift", "dt", "order"):
        assert table[col].dtype.kind == "f", col
        pd.testing.assert_series_equal(table[col], original[col])
    for col in ("engine_variant", "reason", "status"):
        assert list(table[col]) == list(original[col]), col
    md, _ = write_report(merged)
    assert md.read_text().count("## ") >= 2


LEGIBILITY = """<script>
window.addEventListener("load", () => {
  const rgb = c => (c.match(/\\d+(\\.\\d+)?/g) || []).slice(0, 4).map(Number);
  const cells = Array.from(document.querySelectorAll(
      "table.board td, table.board th, table.legend td, #overview ~ p"))
    .slice(0, 4000).filter(el => el.textContent.trim().length > 0)
    .map(el => { const cs = getComputedStyle(el);
                 return {text: el.textContent.trim().slice(0, 40), size: parseFloat(cs.fontSize),
                         color: rgb(cs.color), background: rgb(cs.backgroundColor)}; });
  const out = document.createElement("pre");
  out.id = "refsim-legibility";
  out.textContent = JSON.stringify(cells);
  document.body.appendChild(out);
});
</script>"""


def _relative_luminance(rgb) -> float:
    def channel(c):
        c = c / 255
        return c / 12.92 if c <= 0.03928 else ((c + 0.055) / 1.055) ** 2.4
    return 0.2126 * channel(rgb[0]) + 0.7152 * channel(rgb[1]) + 0.0722 * channel(rgb[2])


def test_overview_is_legible_at_100_percent_in_chromium(browser, run_dir, tmp_path):
    """As Chromium lays the page out at 100 % zoom: every text cell of the scoreboard and its
    colour legend, and every line of the per-engine summary, at least 10 px, and its text at
    least 4.5:1 against its background (WCAG AA; a transparent background is the white page);
    the scoreboard is an HTML table, not a picture of one; a screenshot of the overview at
    1280 x 1600 is not blank."""
    page = (run_dir / "report.html").read_text()
    assert '<table class="board">' in page and '<table class="legend">' in page
    checked = tmp_path / "legibility.html"
    checked.write_text(page.replace("<head>", "<head>" + LEGIBILITY, 1))
    found = re.search(r'<pre id="refsim-legibility">([^<]*)</pre>', _dump_dom(browser, checked))
    assert found, "the legibility script did not run"
    cells = json.loads(html.unescape(found.group(1)))
    assert len(cells) >= 10  # a header, group rows, 2 x 2 cells, the legend, two engine lines
    small = [c for c in cells if c["size"] < 10]
    assert not small, small[:3]
    low = []
    for c in cells:
        background = c["background"] if len(c["background"]) == 3 or (
            len(c["background"]) == 4 and c["background"][3] > 0) else [255, 255, 255]
        lum = sorted((_relative_luminance(c["color"]), _relative_luminance(background)))
        ratio = (lum[1] + 0.05) / (lum[0] + 0.05)
        if ratio < 4.5:
            low.append((c["text"], round(ratio, 2)))
    assert not low, low[:5]
    shot = tmp_path / "overview.png"
    subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                    f"--screenshot={shot}", "--window-size=1280,1600",
                    (run_dir / "report.html").as_uri() + "#overview"],
                   capture_output=True, timeout=120, check=True)
    import matplotlib.image as mpimg
    pixels = mpimg.imread(shot)
    assert pixels.shape[:2] == (1600, 1280) and pixels[..., :3].std() > 0.05


def test_a_cells_colour_is_on_the_side_of_its_word(run_dir):
    """On the run's real scoreboard and on the whole colour scale: a cell that reaches the
    target is coloured on the green side, one short of it on the red side (the scale leaves a
    gap around its middle), and its text colour reads at least 4.5:1 on it."""
    from refsim.report.board import colour, contrast, ratio_of, text_colour
    from refsim.report.overview import scoreboard
    from refsim.store.definitions import Definitions
    board = scoreboard(load_results(run_dir), Definitions.of_run(run_dir))
    ran = board[board["verdict"].isin(("reaches the target", "does not reach the target"))]
    assert set(ran["verdict"]) == {"reaches the target", "does not reach the target"}
    for _, r in ran.iterrows():
        ratio = ratio_of(r)
        assert (ratio <= 0) == (r["verdict"] == "reaches the target"), (r["case"], ratio)
    green, red = colour(-1e-9), colour(1e-9)
    g, r_ = (int(green[k:k + 2], 16) for k in (1, 3)), (int(red[k:k + 2], 16) for k in (1, 3))
    (gr, gg), (rr, rg) = g, r_
    assert gg > gr and rr > rg  # green dominates below the target, red above it
    for k in np.linspace(-6, 6, 241):
        assert contrast(colour(k), text_colour(colour(k))) >= 4.5
