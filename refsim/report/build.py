"""`refsim report RUN_DIR`: report.md and a self-contained report.html from a stored run.

Reads the store only (results.csv, manifest.json, series.jsonl and the cases as run,
cases.json: description, units, energy scale, target error, error floor, figures); nothing is
re-run. First the overview (refsim.report.overview: the scoreboard of case/variant x engine and
its heatmap), then per case and variant: the recommendation (the cheapest configuration
reaching the target error), a compact table, measured against nominal orders where the case
declares an order meaningful, and the figures (refsim.report.plots, small multiples styled by
refsim.report.style): work-precision (error against run time, Pareto fronts), convergence
(error against dt, fitted orders where meaningful), energy against time at the reference dt,
and the figures the case declares (e.g. the dam break's surge front over the experiment). A
declared figure carrying `"shared": id` is drawn once, in the first section declaring that id,
with the rows of every section declaring it (e.g. the SPH and FLIP dam breaks' fronts side by
side, a cavity's grids on the same axes): `declared_figures`.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from refsim.report import plots
from refsim.store.definitions import Definitions
from refsim.report.overview import overview_blocks, truthy
from refsim.report.render import render_html, render_markdown
from refsim.report.style import Style

from refsim.verdicts import ORDER_SLACK  # |measured - nominal| within it: "matches"


# ---------------------------------------------------------------------------------------------
# Content: a list of blocks, rendered twice (Markdown, HTML)
# ---------------------------------------------------------------------------------------------
def write_report(run_dir, target_error=None, out=None):
    from refsim.store.results import load_results, load_series
    run_dir = Path(run_dir)
    out = Path(out or run_dir)
    table = load_results(run_dir)
    manifest = json.loads((run_dir / "manifest.json").read_text())
    series = load_series(run_dir)
    definitions = Definitions.of_run(run_dir)
    table = _with_targets(table, definitions, target_error)
    style = Style.of_table(table)
    blocks = _header(manifest, table) + [("nav",)]
    blocks += overview_blocks(table, definitions, target_error, out, style)
    blocks += work_blocks(table, definitions)
    sections = [(definitions.of_row(rows.iloc[0]), rows)
                for _, rows in table.groupby(["case", "variant"], sort=False)]
    for section in _render_sections(sections, series, target_error, out, style):
        blocks += section
    if definitions.legacy:
        blocks.insert(4, ("p", "This run was stored before runs kept their case definitions: "
                               "descriptions, units and figures come from today's code."))
    md_path, html_path = out / "report.md", out / "report.html"
    out.mkdir(parents=True, exist_ok=True)
    md_path.write_text(render_markdown(blocks, out))
    html_path.write_text(render_html(blocks, manifest))
    return md_path, html_path


def _with_targets(table, definitions, target_error):
    """reaches_target against `--target-error` when given, else as stored; a run stored
    before the column existed gets it from its stored case definitions."""
    if "reaches_target" in table and target_error is None:
        return table
    table = table.copy()
    reach = []
    for _, r in table.iterrows():
        d = definitions.of_row(r)
        target = float(d["target_error"]) if target_error is None else target_error
        value = float(r.get(d["tolerance_column"], np.nan))
        reach.append(bool(r["status"] == "ok" and np.isfinite(value) and value <= target))
    table["reaches_target"] = reach
    return table


_SECTIONS: tuple = ()  # what forked workers render (set just before the pool forks)


def _render_section(k):
    sections, series, target_error, out, style = _SECTIONS
    d, rows = sections[k]
    return _case_section(d, rows, series, target_error, out, style,
                         declared_figures(sections, k))


def declared_figures(sections, k) -> list:
    """Section k's declared figures: (spec, rows, file stem) to draw, or ("p", text) for a
    shared one drawn elsewhere. A figure carrying "shared": id is drawn in the first section
    declaring that id, once, with the rows of every section declaring it, each row's section
    in the column `figure_group` ("case/variant", or the spec's "legend_params" as "n=32"),
    sections ordered by those parameters where they are numbers (coarse to fine grids)."""
    d, rows = sections[k]
    out = []
    for j, spec in enumerate(d.get("figures", [])):
        sid = spec.get("shared")
        if not sid:
            out.append((spec, rows, f"fig{j}"))
            continue
        owners = [i for i, (di, _) in enumerate(sections)
                  if any(f.get("shared") == sid for f in di.get("figures", []))]
        names = ", ".join(_section_title(sections[i][0]) for i in owners)
        if owners[0] != k:
            out.append(("p", f"Figure \"{spec['title']}\" ({names}) is drawn once, in section "
                             f"{_section_title(sections[owners[0]][0])}."))
            continue
        keys = spec.get("legend_params") or []
        labelled = [(_group_label(sections[i][0], keys), _group_order(sections[i][0], keys), i)
                    for i in owners]
        shared = pd.concat([sections[i][1].assign(figure_group=label)
                            for label, _, i in sorted(labelled, key=lambda g: g[1])])
        out.append(({**spec, "title": f"{spec['title']} ({names})"}, shared, "shared-"
                    + "".join(c if c.isalnum() else "_" for c in str(sid))))
    return out


def _section_title(d) -> str:
    return f"{d['case']} / {d['variant']}"


def _group_label(d, keys) -> str:
    """A shared figure's name for a section's rows: its parameters `keys` ("n=32"), else its
    case and variant."""
    if not keys:
        return f"{d['case']}/{d['variant']}"
    return " ".join(f"{key}={_fmt(d['params'].get(key), 'g')}" for key in keys)


def _group_order(d, keys) -> tuple:
    """Sections by their parameters `keys` where numbers (coarse to fine), else as run."""
    values = [d["params"].get(key) for key in keys]
    return tuple(v if isinstance(v, (int, float)) else math.inf for v in values)


def _render_sections(sections, series, target_error, out, style) -> list:
    """Each case section (its figures are most of the report's time) in its own worker
    process, min(2, cores) at a time (forked: the run's table and series are inherited, not
    pickled); in order, one process where fork is unavailable."""
    import multiprocessing as mp
    import os
    global _SECTIONS
    _SECTIONS = (sections, series, target_error, out, style)
    workers = min(2, os.cpu_count() or 1, len(sections))
    try:
        if workers > 1 and "fork" in mp.get_all_start_methods():
            with mp.get_context("fork").Pool(workers) as pool:
                return pool.map(_render_section, range(len(sections)), chunksize=1)
        return [_render_section(k) for k in range(len(sections))]
    finally:
        _SECTIONS = ()


def _fmt(value, spec=".3g") -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return format(value, spec)


def _header(manifest, table):
    counts = table["status"].value_counts().to_dict()
    engines = ", ".join(f"{k} {v}" for k, v in manifest.get("engines", {}).items())
    from refsim.run.summary import verdict_counts
    verdicts = verdict_counts(table)
    counts["ok"] = f"{counts.get('ok', 0)} (" + ", ".join(
        f"{k} {v}" for k, v in verdicts.items()) + ")"
    blocks = [("h1", f"refsim report: run {manifest.get('run_id', '?')}"),
              ("p", f"Command `{manifest.get('command', '?')}`, commit "
                    f"{str(manifest.get('git_commit', '?'))[:12]}, "
                    f"{manifest.get('timestamp', '?')}."),
              ("p", f"Machine: {manifest.get('cpu', '?')}; {manifest.get('threads', '?')} "
                    f"BLAS/OpenMP thread(s); Python {manifest.get('python', '?')}, numpy "
                    f"{manifest.get('numpy', '?')}. Engines: {engines}."),
              ("p", f"{len(table)} rows: " + ", ".join(f"{k} {v}" for k, v in counts.items())
               + ".")]
    if "harness_overhead" in manifest:
        blocks.append(("p", f"Run time {manifest['wall_s']:.1f} s on "
                            f"{manifest.get('workers', 1)} worker process(es), one thread "
                            f"each; harness overhead {100 * manifest['harness_overhead']:.1f} % "
                            "of the work (the rest is the engines' setup, compilation, "
                            "stepping and observation)."))
    blocks.append(("p", "Run time below is the time stepping the whole simulated interval "
                        "(timing pass: fresh models, nothing observed, min of repeats; setup "
                        "and compilation apart; a long run timed over its first `timed_steps` "
                        "steps and scaled). Error is the case's compared norm at every sample "
                        "against its reference. Each row's status gives its two verdicts: "
                        "consistent or INCONSISTENT ! with the method it names (its bound and "
                        "reason in tol_reason), and whether it reaches the case's target."))
    return blocks


def _case_section(d, rows, series, target_error, out, style=None, declared=None):
    """One case x variant from its stored definition `d` (Case.definition); `declared`: its
    declared figures (`declared_figures`), else its own figures with its own rows."""
    from refsim.store.results import row_key
    col, observable, units = d["tolerance_column"], d["observable"], d["units"]
    target = target_error if target_error is not None else d["target_error"]
    title = f"{d['case']} / {d['variant']}"
    slug = title.replace(" / ", "-").replace("/", "_").replace(" ", "_").replace("=", "")
    compared = f" Compared: `{col}` of {observable} ({units})." if observable else ""
    blocks = [("h2", title), ("p", f"{d['description']}.{compared}")]
    if "wall_s" in rows:  # a bench's or a stress run's rows have no work column
        blocks.append(("p", _work_line(rows)))
    if math.isfinite(target):  # a definition with no target error gets no recommendation
        blocks.append(("p", recommendation(rows, col, units, target)))
    ran = rows[np.isfinite(rows["dt"])]
    style = style or Style.of_table(rows)
    meaningful = bool(d.get("order_meaningful", True))
    floor = d.get("error_floor")
    figures = [
        plots.work_precision(ran, col, units, out / "plots" / f"{slug}-work.png",
                             f"{title}: work-precision", style, floor),
        plots.convergence(ran, col, units, out / "plots" / f"{slug}-conv.png",
                          f"{title}: convergence", style, floor, show_orders=meaningful),
        plots.energy_history(ran, series, row_key, d["energy_scale"],
                             out / "plots" / f"{slug}-energy.png",
                             f"{title}: energy drift so far at the reference dt", style),
    ]
    notes = []
    for item in declared if declared is not None else declared_figures([(d, rows)], 0):
        if item[0] == "p":
            notes.append(item)
            continue
        spec, drawn, stem = item
        draw = plots.FIGURES.get(spec.get("kind"))
        if draw is not None:
            shared = stem.startswith("shared-")  # named by its id and its sections
            figures.append(draw(drawn, series, row_key, spec, out / "plots" / (
                f"{stem}.png" if shared else f"{slug}-{stem}.png"),
                spec["title"] if shared else f"{title}: {spec['title']}", style))
    from refsim.report.render import webp  # encoded here, in the section's worker
    blocks += [("img", f, title, webp(f)) for f in figures if f is not None] + notes
    orders = order_table(ran) if meaningful else pd.DataFrame()
    if len(orders):
        blocks += [("h3", "Measured against nominal order"), ("table", orders)]
    blocks += [("h3", "Results"), ("table", compact_table(rows, col, d.get("report_columns", ()),
                                                          orders=meaningful))]
    return blocks


def work_blocks(table, definitions) -> list:
    """Where the run's work went: seconds per model group and engine (a row's wall_s: both
    passes and the harness's checks in its worker), largest first."""
    from refsim.run.budget import work_by
    from refsim.store.definitions import model_group
    if "wall_s" not in table or table.empty:
        return []
    groups = {c: model_group(definitions, c) for c in table["case"].unique()}
    work = work_by(table.assign(model_group=table["case"].map(groups)),
                   ["model_group", "engine"])
    total = float(work["work_s"].sum())
    grid = work.pivot_table(index="model_group", columns="engine", values="work_s",
                            aggfunc="sum", fill_value=0.0)
    grid["all engines"] = grid.sum(axis=1)
    grid = grid.sort_values("all engines", ascending=False)
    jobs = work.groupby("model_group")["jobs"].sum()
    shown = pd.DataFrame({"model group": grid.index,
                          **{e: [f"{w:.1f}" if w else "-" for w in grid[e]] for e in grid},
                          "jobs": [int(jobs[g]) for g in grid.index],
                          "share": [f"{100 * w / max(total, 1e-12):.1f} %"
                                    for w in grid["all engines"]]})
    return [("h2", "Work per model group", "work"),
            ("p", f"{total:.0f} s of work in {len(table)} jobs, in seconds per model group "
                  "and engine (each row's wall time in its worker: both passes and the "
                  "harness's checks); the case sections give each case's own."),
            ("table", shown)]


def _work_line(rows) -> str:
    work = pd.to_numeric(rows["wall_s"], errors="coerce").fillna(0.0)
    return f"Work: {work.sum():.1f} s in {len(rows)} jobs."


def recommendation(rows, col, units, target) -> str:
    """The cheapest configuration (least stepping time) with its error at or below target."""
    ok = rows[(rows["status"] == "ok") & np.isfinite(rows[col]) & np.isfinite(rows["step_s"])]
    if ok.empty:
        return f"Recommendation: no configuration ran to the end (target {target:.3g} {units})."
    good = ok[ok[col] <= target]
    if good.empty:
        best = ok.loc[ok[col].idxmin()]
        return (f"Recommendation: none reaches the target {col} <= {target:.3g} {units}; the "
                f"most accurate is {_config(best)} with {best[col]:.3g} in "
                f"{best['step_s']:.3g} s.")
    best = good.loc[good["step_s"].idxmin()]
    return (f"Recommendation: to reach {col} <= {target:.3g} {units}, the cheapest is "
            f"**{_config(best)}**: {best[col]:.3g} {units} in {best['step_s']:.3g} s "
            f"({best['us_per_step']:.3g} us/step; {len(good)} of {len(ok)} configurations "
            f"reach the target).")


def _config(row) -> str:
    return f"{plots.line_label(row)} at dt = {row['dt']:.3g} s"


def order_table(rows) -> pd.DataFrame:
    """Measured convergence order (fit over the asymptotic dt range) against nominal."""
    ok = rows[(rows["status"] == "ok") & (rows.get("order_points", 0) >= 2)]
    out = []
    for _, sub in ok.groupby(["engine", "engine_variant", "integrator"], sort=False):
        r = sub.iloc[0]
        nominal, measured = r["nominal_order"], r["order"]
        verdict = "-" if not (np.isfinite(nominal) and np.isfinite(measured)) else (
            "matches" if abs(measured - nominal) <= ORDER_SLACK else
            "below the method's" if measured < nominal else "above the method's")
        declared = float(r.get("declared_order", np.nan))
        entry = {"engine": plots.line_label(r).rsplit(" ", 1)[0],
                 "integrator": r["integrator"], "method's order": _fmt(nominal, "g"),
                 "engine declares": _fmt(declared, "g"),
                 "measured": _fmt(measured, ".2f")}
        if np.isfinite(float(r.get("order_dt_lo", np.nan))):
            entry["dt range"] = f"{r['order_dt_lo']:.3g}..{r['order_dt_hi']:.3g}"
        if "order_stderr" in r:
            entry["stderr"] = _fmt(r["order_stderr"], ".2f")
        entry.update({"points": int(r["order_points"]), "verdict": verdict})
        if "order_note" in r:
            note = r["order_note"]
            entry["note"] = str(note) if isinstance(note, str) and note else "-"
        out.append(entry)
    return pd.DataFrame(out)


def _row_status(r) -> str:
    """ok with the row's two verdicts (the method's bound and the case's target), or the
    status with its reason."""
    if r["status"] != "ok":
        return f"{r['status']}: {r['reason']}"
    if not str(r.get("consistency", "")) and np.isnan(float(r.get("tolerance", np.nan))):
        return "ok (no tolerance)"  # a figure nothing bounds (refsim.store.figures)
    verdict = str(r.get("consistency", "")) or "no verdict"
    if verdict == "inconsistent":
        verdict = f"INCONSISTENT ! ({r.get('consistency_reason', '')})"
    declared, nominal = float(r.get("declared_order", np.nan)), float(r.get("nominal_order",
                                                                            np.nan))
    if np.isfinite(declared) and declared != nominal:
        verdict += f" (declares order {declared:g}, the method's is {nominal:g})"
    target = "reaches the target" if truthy(r.get("reaches_target")) else "short of the target"
    return f"ok, {verdict}, {target}"


def compact_table(rows, col, extra=(), orders=True) -> pd.DataFrame:
    """One line per row; `extra`: further columns the stored definition asks to show; the
    measured order only where the case declares one meaningful (`orders`)."""
    out = []
    for _, r in rows.iterrows():
        status = _row_status(r)
        out.append({"engine": plots.line_label(r).rsplit(" ", 1)[0] if r["integrator"] else
                    r["engine"], "integrator": r["integrator"] or "-",
                    "dt": _fmt(r["dt"]), col: _fmt(r[col], ".2e"),
                    "energy_drift": _fmt(r["energy_drift"], ".2e"),
                    "order": _fmt(r.get("order", np.nan), ".2f"),
                    "us/step": _fmt(r["us_per_step"]), "status": status,
                    **{c: _cell(r.get(c)) for c in extra}})
    table = pd.DataFrame(out)
    return table if orders or table.empty else table.drop(columns="order")


def _cell(value) -> str:
    if isinstance(value, float) and math.isinf(value):
        return str(value)  # an unbounded figure (e.g. a stability limit) is data, not "-"
    if value is None or isinstance(value, (int, float)):
        return _fmt(value, ".4g")
    return str(value)
