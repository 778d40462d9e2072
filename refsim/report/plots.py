"""The report's figures, drawn from a stored run's table and time series (matplotlib, Agg).

Each function takes the rows of one case variant and writes one PNG, returning its path, or
None when there is nothing to draw (no `ok` row, no stored series). Every figure is small
multiples (refsim.report.style.panels: at most MAX_SERIES series per axes), colours by engine
and markers by integrator from one `Style` shared by the whole report; errors at or below the
case's error floor (0 included) are drawn on the labelled "exact to round-off" band.

The figures a case declares (Case.figures: FIGURES, by kind) draw its rows' stored series; a
declared figure shared by several case sections (refsim.report.build) gets the rows of all of
them, each row's section named in the column `figure_group` (its legend and small multiples
say whose row it is).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from refsim.report import style as rs
from refsim.report.limits import stability_limits


def line_label(row) -> str:
    ev = row["engine_variant"]
    return f"{row['engine']}{':' + ev if ev else ''} {row['integrator']}"


def _series(rows: pd.DataFrame, column: str) -> list[tuple]:
    """[(engine, formulation, integrator, sub-table sorted by dt)] over `ok` rows with a finite
    value >= 0 in `column` (0, exact to round-off, is kept: it goes on the band)."""
    ok = rows[(rows["status"] == "ok") & np.isfinite(rows[column]) & (rows[column] >= 0)]
    # the columns the figures read: grouping and sorting the run's ~100 columns took 4 % of
    # the report's time
    ok = ok[list(dict.fromkeys(c for c in ("engine", "engine_variant", "integrator", "dt",
                                          column, "step_s", "order") if c in ok))]
    return [(*key, sub.sort_values("dt")) for key, sub in
            ok.groupby(["engine", "engine_variant", "integrator"], sort=False)]


def pareto_front(err: np.ndarray, cost: np.ndarray) -> np.ndarray:
    """Indices of the points no other point beats in both error and cost, by rising error."""
    order = np.lexsort((cost, err))
    front, best = [], np.inf
    for k in order:
        if cost[k] < best:
            front.append(k)
            best = cost[k]
    return np.asarray(front, int)


def _draw_front(ax, err, cost, floor, **kwargs) -> None:
    front = pareto_front(err, cost)
    ax.step(rs.on_band(err[front], floor), cost[front], where="post", **kwargs)


def _fronts_panel(ax, series, err_col, floor, style) -> None:
    """Each engine's Pareto front in its colour; the overall front black dashed."""
    points = pd.concat([s[3] for s in series])
    for engine, sub in points.groupby("engine", sort=False):
        _draw_front(ax, sub[err_col].to_numpy(float), sub["step_s"].to_numpy(float), floor,
                    color=style.colour(engine), lw=1.4, marker="o", ms=3, label=engine)
    err, cost = points[err_col].to_numpy(float), points["step_s"].to_numpy(float)
    _draw_front(ax, err, cost, floor, color="k", ls="--", lw=1.0, label="all engines")
    front = pareto_front(err, cost)
    ax.plot(rs.on_band(err[front], floor), cost[front], "ks", mfc="none", ms=6)


def work_precision(rows, err_col, units, path: Path, title: str, style=None, floor=None):
    """Error (log x) against run time to t_end (log y): a first panel of each engine's Pareto
    front (and the overall one), then per engine one line per formulation and integrator
    across the dt sweep."""
    style = style or rs.Style.of_table(rows)
    timed = rows[np.isfinite(rows["step_s"]) & (rows["step_s"] > 0)]
    series = _series(timed, err_col)
    if not series:
        return None
    floor = rs.floor_of(floor, timed[err_col])
    facets = rs.panels(series)
    fig, axes = rs.grid_figure(1 + len(facets))
    for ax in axes:  # log scales first: setting a scale resets the axis's ticks and labels,
        ax.set_xscale("log")  # which finish_axes sets
        ax.set_yscale("log")
    _fronts_panel(axes[0], series, err_col, floor, style)
    rs.finish_axes(axes[0], "Pareto fronts")
    for ax, (name, members) in zip(axes[1:], facets):
        for engine, form, integrator, sub in members:
            ax.plot(rs.on_band(sub[err_col], floor), sub["step_s"],
                    label=integrator + (f" [{form}]" if form and form not in name else ""),
                    **style.line_kwargs(engine, integrator))
        rs.finish_axes(ax, name)
    for ax in axes:
        rs.draw_band(ax, floor, "x")
        ax.set_xlabel(f"{err_col} ({units})", fontsize=7)
        ax.set_ylabel("run time to t_end (s)", fontsize=7)
    return rs.save(fig, path, title)


def convergence(rows, err_col, units, path: Path, title: str, style=None, floor=None,
                show_orders=True):
    """Error against dt (log-log) per engine; the legend gives each line's fitted order when
    the case declares an order meaningful (`show_orders`)."""
    style = style or rs.Style.of_table(rows)
    series = [s for s in _series(rows, err_col) if s[3]["dt"].nunique() > 1]
    if not series:
        return None
    floor = rs.floor_of(floor, rows[err_col])
    facets = rs.panels(series)
    fig, axes = rs.grid_figure(len(facets))
    for ax, (name, members) in zip(axes, facets):
        for engine, form, integrator, sub in members:
            order = sub["order"].iloc[0] if "order" in sub else np.nan
            tag = f" (p={order:.2f})" if show_orders and np.isfinite(order) else ""
            form_tag = f" [{form}]" if form and form not in name else ""
            ax.plot(sub["dt"], rs.on_band(sub[err_col], floor),
                    label=integrator + form_tag + tag, **style.line_kwargs(engine, integrator))
        ax.set_xscale("log")
        ax.set_yscale("log")
        rs.draw_band(ax, floor, "y")
        ax.set_xlabel("dt (s)", fontsize=7)
        ax.set_ylabel(f"{err_col} ({units})", fontsize=7)
        rs.finish_axes(ax, name)
    return rs.save(fig, path, title)


def _traced(rows, series: dict, key_of, *fields: str):
    """(row, its stored series) for every row whose series holds every one of `fields`."""
    for _, row in rows.iterrows():
        trace = series.get(key_of(row))
        if trace and all(field in trace for field in fields):
            yield row, trace


def _group(row) -> str:
    """The section a row of a shared figure comes from ("" in a case's own figure)."""
    group = row.get("figure_group", "")
    return group if isinstance(group, str) else ""


def _traced_panels(rows, series, key_of, *fields, by_group=True):
    """Small multiples of the rows holding stored `fields`, as for the sweeps: by engine, and
    in a shared figure by section first (`by_group`) or all sections on the same axes."""
    traced = [(" ".join(filter(None, (_group(r) if by_group else "", r["engine"]))),
               r["engine_variant"], r["integrator"], (r, t))
              for r, t in _traced(rows, series, key_of, *fields)]
    return rs.panels(traced) if traced else []


def energy_history(rows, series: dict, key_of, scale: float, path: Path, title: str,
                   style=None):
    """max over [0, t] of |E - E(0)| / energy scale at the reference dt (log scale, round-off
    floored at 1e-16), one line per engine and integrator, small multiples by engine. The
    running maximum (the drift so far) shows bounded against growing error as a plateau
    against a rise, and a monotone line is a fifth of the PNG bytes of the raw round-off
    noise (the report's 2 MB budget)."""
    style = style or rs.Style.of_table(rows)
    facets = _traced_panels(rows, series, key_of, "energy")
    if not facets:
        return None
    fig, axes = rs.grid_figure(len(facets))
    for ax, (name, members) in zip(axes, facets):
        for _, form, integrator, (row, trace) in members:
            e = np.asarray(trace["energy"], float)
            kwargs = {**style.line_kwargs(row["engine"], integrator),
                      "markevery": max(1, len(e) // 8)}
            drift = np.maximum.accumulate(np.abs(e[1:] - e[0]) / scale)
            ax.semilogy(trace["t"][1:], np.maximum(drift, 1e-16),
                        label=integrator + (f" [{form}]" if form and form not in name else ""),
                        **kwargs)
        ax.set_xlabel("t (s)", fontsize=7)
        ax.set_ylabel("max |E - E(0)| so far / energy scale", fontsize=7)
        rs.finish_axes(ax, name)
    return rs.save(fig, path, title)


def trace_over_data(rows, series: dict, key_of, spec: dict, path: Path, title: str,
                    style=None):
    """A case's declared figure (Case.figures, kind "trace_over_data"): each row's stored
    series spec["y"] against spec["x"] (shifted by the row's spec["x_shift_column"] when
    given), over the measured points spec["data"]; small multiples by engine."""
    style = style or rs.Style.of_table(rows)
    facets = _traced_panels(rows, series, key_of, spec["x"], spec["y"])
    if not facets:
        return None
    column, data = spec.get("x_shift_column"), spec["data"]
    fig, axes = rs.grid_figure(len(facets))
    for ax, (name, members) in zip(axes, facets):
        for _, form, integrator, (row, trace) in members:
            shift = float(row.get(column, 0.0)) if column else 0.0
            shift = 0.0 if not np.isfinite(shift) else shift
            label = line_label(row)  # its case and variant: the panel's title
            if column:
                label += f" (shift {shift:+.2f}, RMS {row['err_rms']:.3f})"
            kwargs = {**style.line_kwargs(row["engine"], integrator), "lw": 1.2,
                      "markevery": max(1, len(trace[spec["y"]]) // 8)}
            ax.plot(np.asarray(trace[spec["x"]]) + shift, trace[spec["y"]], label=label,
                    **kwargs)
        ax.plot(data["x"], data["y"], "ko", ms=4, mfc="none", label=data["label"])
        ax.set_xlabel(spec["x_label"], fontsize=7)
        ax.set_ylabel(spec["y_label"], fontsize=7)
        rs.finish_axes(ax, name)
    _same_limits(axes)
    return rs.save(fig, path, title)


def _same_limits(axes) -> None:
    """One x and one y range over the axes, so that side-by-side panels compare by eye."""
    if len(axes) > 1:
        x = np.array([ax.get_xlim() for ax in axes])
        y = np.array([ax.get_ylim() for ax in axes])
        for ax in axes:
            ax.set_xlim(x[:, 0].min(), x[:, 1].max())
            ax.set_ylim(y[:, 0].min(), y[:, 1].max())


# light to dark blues: a shared profile figure's sections, coarse to fine
PROFILE_COLOURS = ("#9ecae1", "#6baed6", "#4292c6", "#2171b5", "#08519c", "#08306b")


def profile(rows, series: dict, key_of, spec: dict, path: Path, title: str, style=None):
    """A case's declared figure (Case.figures, kind "profile"): each row's stored last-sample
    profile (its series' spec panel["y"]: one value per coordinate of panel["x"]) against
    those coordinates, over the measured points panel["data"] and the case's own reference
    lines panel["lines"] (dashed); one axes per panel and engine (per formulation where an
    engine has many lines). The rows of several sections (a shared figure: grids n = 16, 32,
    ...) share the axes, coloured light to dark in their order (coarse to fine), marked by
    integrator, so that convergence shows as lines closing on the data."""
    style = style or rs.Style.of_table(rows)
    panels = spec["panels"]
    facets = _traced_panels(rows, series, key_of, *(panel["y"] for panel in panels),
                            by_group=False)
    if not facets:
        return None
    groups = list(dict.fromkeys(_group(m[3][0]) for _, members in facets for m in members))
    fig, axes = rs.grid_figure(len(facets) * len(panels))
    for k, (name, members) in enumerate(facets):
        for panel, ax in zip(panels, axes[k * len(panels):]):
            x = np.asarray(panel["x"], float)
            for _, form, integrator, (row, trace) in members:
                y = np.asarray(trace[panel["y"]], float)
                if y.shape != x.shape:  # stored with other coordinates: not drawn against these
                    continue
                colour = _ramp(groups.index(_group(row)), len(groups)) if len(groups) > 1 \
                    else style.colour(row["engine"])
                marker, ls = style.marker(integrator)
                form_tag = f" [{form}]" if form and form not in name else ""
                ax.plot(x, y, color=colour, marker=marker, ls=ls, ms=3.5, lw=1.1,
                        markevery=max(1, len(x) // 8),
                        label=" ".join(filter(None, (_group(row), integrator + form_tag))))
            for line in panel.get("lines") or []:
                ax.plot(line["x"], line["y"], color="#d62728", ls="--", lw=1.0,
                        label=line["label"])
            data = panel["data"]
            ax.plot(data["x"], data["y"], "ko", ms=4, mfc="none", label=data["label"])
            ax.set_xlabel(panel["x_label"], fontsize=7)
            ax.set_ylabel(panel["y_label"], fontsize=7)
            rs.finish_axes(ax, f"{name}: {panel['y']}")
    return rs.save(fig, path, title)


def _ramp(k: int, count: int) -> str:
    """The k-th of `count` colours spread over PROFILE_COLOURS, light to dark."""
    last = len(PROFILE_COLOURS) - 1
    return PROFILE_COLOURS[min(last, round(k * last / max(1, count - 1)))]


FIGURES = {"trace_over_data": trace_over_data,  # the kinds a case may declare
           "profile": profile,
           "stability_limits": stability_limits}
