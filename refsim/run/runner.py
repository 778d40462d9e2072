"""Expands the case x engine x integrator x dt matrix and runs it with timing discipline.

Each job is two passes on fresh models: an accuracy pass (step to each sample time, observe,
check for divergence) and a timing pass (warm-up, then `Sim.step(N)` repeated with nothing
observed; min and median kept). A failure is a row with a status, never a crash of the sweep.
"""
from __future__ import annotations

import json
import time
from dataclasses import asdict

import numpy as np
import pandas as pd

from refsim.registry import engine_names, get_engine
from refsim.registry import case_names, get_case
from refsim.integrators import INTEGRATORS, PARAMETRISED, get_integrator
from refsim.integrators.spec import IntegratorSpec, spec_name
from refsim.options import MAX_STEPS, check_dt, check_steps
from refsim.run.job import BUDGET_S, Job
from refsim.case import adaptive_rtol
from refsim.run.metrics import OrderFit, fit_order
from refsim.verdicts import CONSISTENT, INCONSISTENT, order_reason

# ---------------------------------------------------------------------------------------------
# Matrix expansion
# ---------------------------------------------------------------------------------------------
def check_integrators(integrators, engines) -> None:
    """Each spec names an integrator some engine offers; a parameter after ':' is given and in
    its range ('rk2:' would run the default rk2 under another row key)."""
    offered = {i for e in engines for i in e.integrators}
    offered |= {i for e in engines for g in e.model_groups() for i in g.integrators or ()}
    for spec in integrators:
        parsed = IntegratorSpec.parse(spec)
        name = parsed.name
        if parsed.colon and not parsed.arg:
            hint = PARAMETRISED.get(name, "this integrator takes none")
            raise ValueError(f"integrator {spec!r}: a parameter must follow ':' ({hint}), "
                             f"or leave out the ':' for the default")
        if name in INTEGRATORS:
            get_integrator(spec)  # validates a parameter such as rk2:alpha
        if name not in offered:
            raise ValueError(f"integrator must be one of {sorted(offered)} for engines "
                             f"{[e.name for e in engines]}, got {spec!r}")


def expand(cases=None, engines=None, integrators=None, dts=None, quick=False, variants=None,
           params=None, full=False, max_steps=MAX_STEPS) -> list[Job]:
    """Every job of the matrix; unknown names raise ValueError naming the valid ones, and so
    does a dt longer than a run or giving more than `max_steps` steps.

    The dt sweep runs each engine's default formulation; its alternatives (the KKT and penalty
    pendulum, taichi's kernel-launch-per-step, MuJoCo's coupled contacts...) compare terms at
    the case's reference dt only (not at all with `quick`, nor on variants outside a case's
    `alternatives_variants` unless they are named), unless `full` (or explicit `dts`) asks
    for the whole sweep."""
    cases = list(cases or case_names())
    for name in cases:
        get_case(name)
    engines = ([get_engine(e) for e in engines] if engines else
               [e for e in map(get_engine, engine_names()) if not e.peer])
    dts = [check_dt(d) for d in dts] if dts else None
    if integrators:
        check_integrators(integrators, engines)
    if variants:
        known = sorted({v for c in cases for v in get_case(c).variants})
        for v in variants:
            if v not in known:
                raise ValueError(f"variant must be one of {known}, got {v!r}")
    jobs = []
    for cname in cases:
        case = get_case(cname)
        for variant in _variants(case, variants, quick):
            overrides = tuple(sorted((params or {}).get(cname, {}).items()))
            p = case.variant_params(variant, dict(overrides))
            scene = case.scene(p)
            ref = [case.reference_dt(p)]
            sweep = dts or (ref if quick else case.dts(p))
            alt_sweep = sweep if (full or dts) else ([] if quick else ref)
            if not (full or dts or variants) and case.alternatives_variants and \
                    variant not in case.alternatives_variants:
                alt_sweep = []
            untimed = [] if (quick or dts) else [d for d in case.order_dts(p) if d not in sweep]
            for dt in sweep + untimed:
                check_steps(dt, case.t_end(p), f"{cname}/{variant}", max_steps)
            for engine in engines:
                jobs.extend(Job(**{**asdict(j), "params": overrides}) for j in _engine_jobs(
                    cname, variant, engine, scene, integrators, sweep, alt_sweep, untimed))
    return jobs


def _variants(case, variants, quick):
    if variants:
        chosen = [v for v in variants if v in case.variants]
        return chosen or [next(iter(case.variants))]
    if quick:
        return list(case.quick_variants)
    return list(case.default_variants or case.variants)


def _engine_jobs(cname, variant, engine, scene, integrators, sweep, alt_sweep, untimed=()):
    if not engine.available() or engine.supports(scene) is not None:
        return [Job(cname, variant, engine.name, "", "", float("nan"))]
    offered = engine.offered_integrators(scene)
    specs = [i for i in (integrators or offered) if spec_name(i)
             in offered and engine.supports(scene, i) is None]
    if not specs:  # none of the asked integrators runs this scene: one row says why
        spec = (integrators or offered)[0]
        return [Job(cname, variant, engine.name, "", spec, float("nan"))]
    forms = engine.matrix_formulations(scene)
    return [Job(cname, variant, engine.name, ev, spec, dt)
            for k, ev in enumerate(forms) for spec in specs
            for dt in (sweep if k == 0 else alt_sweep)] + [
        Job(cname, variant, engine.name, forms[0], spec, dt, timed=False)
        for spec in specs if adaptive_rtol(spec) is None for dt in untimed]


# ---------------------------------------------------------------------------------------------
# The matrix
# ---------------------------------------------------------------------------------------------
def run_matrix(jobs, store, repeats=5, budget_s=BUDGET_S, progress=None,
               workers=1, executor=None) -> pd.DataFrame:
    """Runs every job not yet in `store` on `executor` (refsim.run.executors: by default in this
    process for one worker, else `Local(workers)`: separate processes, each on one
    BLAS/taichi thread), storing each row as it arrives; rows keep the jobs' order.
    Leaves on the store `harness_s` (time outside engine calls, in the jobs and in this
    process between them) and `busy_s` (all the time spent on the jobs, summed over
    workers): the harness overhead is their ratio."""
    from refsim.store.results import row_key
    run_id = store.dir.name
    done = store.done_keys()
    todo = [j for j in jobs if row_key(asdict(j)) not in done]
    order = {row_key(asdict(j)): k for k, j in enumerate(jobs)}
    start, waited, fresh = time.perf_counter(), 0.0, []
    results = _results(todo, run_id, repeats, budget_s, executor or _executor(workers))
    for k in range(len(todo)):
        t0 = time.perf_counter()
        job, row = next(results)
        waited += time.perf_counter() - t0
        if progress:
            progress(k + 1, len(todo), job)
        trace = row.pop("series", None)
        if trace is not None:
            store.add_series(row, trace)
        store.add(row)
        fresh.append(row)
    results.close()
    if progress:
        progress(len(todo), len(todo), None)
    store.rows.sort(key=lambda r: order.get(row_key(r), len(order)))
    table = with_orders(pd.DataFrame(store.rows))
    store.write_table(table)
    parent_s = time.perf_counter() - start - waited
    store.harness_s = parent_s + float(sum(r["wall_s"] - r["engine_s"] for r in fresh))
    store.busy_s = parent_s + float(sum(r["wall_s"] for r in fresh))
    return table


def _executor(workers):
    from refsim.run import executors
    return executors.InProcess() if workers <= 1 else executors.Local(workers)


def _results(todo, run_id, repeats, budget_s, executor):
    """(job, row) pairs as the executor finishes them (see refsim.run.executors)."""
    tasks = [(j, run_id, repeats, budget_s) for j in todo]
    if tasks:
        yield from executor.results(tasks, size=_job_size)


def _job_size(job) -> float:
    """A job's work (its case's estimate, Case.work), to start the largest runs first; 0 for
    an engine that does not support the case (no dt: nothing runs)."""
    if not job.dt == job.dt:
        return 0.0
    case = get_case(job.case)
    return case.work(case.variant_params(job.variant, dict(job.params)), job.dt)


GROUP = ["case", "variant", "engine", "engine_variant", "integrator"]


def with_orders(table: pd.DataFrame) -> pd.DataFrame:
    """Adds the measured convergence order of each case x engine x integrator over all its
    ok rows (timed dts and the case's accuracy-only `order_dts`): `order` with its standard
    error `order_stderr`, `order_points` and the dt range `order_dt_lo`..`order_dt_hi`, or NaN
    with `order_note` saying why (at floor, pre-asymptotic, adaptive step, single dt; see
    metrics.fit_order). A fitted order more than ORDER_SLACK below the named method's makes
    the group's consistent rows inconsistent (refsim.verdicts.order_reason)."""
    table = table.copy()
    for col, blank in (("order", np.nan), ("order_stderr", np.nan), ("order_points", 0),
                       ("order_dt_lo", np.nan), ("order_dt_hi", np.nan), ("order_note", "")):
        table[col] = blank
    for key, group in table[table["status"] == "ok"].groupby(GROUP + ["params"], dropna=False):
        case = get_case(key[0])
        if not case.order_meaningful:
            continue
        p = case.variant_params(key[1], json.loads(key[-1]))
        fit = _group_order(case, p, key[4], group)
        table.loc[group.index, ["order", "order_stderr", "order_points", "order_dt_lo",
                                "order_dt_hi", "order_note"]] = \
            [fit.order, fit.stderr, fit.points, fit.dt_lo, fit.dt_hi, fit.note]
        _order_verdict(table, group, fit)
    return table


def _order_verdict(table, group, fit) -> None:
    if "consistency" not in table:
        return
    why = order_reason(fit.order, fit.stderr, fit.dt_lo, fit.dt_hi,
                       float(group["nominal_order"].max()))
    if why is None:
        return
    hit = group.index[group["consistency"] == CONSISTENT]
    table.loc[hit, "consistency"] = INCONSISTENT
    table.loc[hit, "consistency_reason"] = why


ADAPTIVE_NOTE = "adaptive step: dt is the output interval, no order in it"
SINGLE_DT_NOTE = "single dt"


def _group_order(case, p, integrator, group) -> OrderFit:
    if adaptive_rtol(integrator) is not None:
        return OrderFit(note=ADAPTIVE_NOTE)
    if group["dt"].nunique() < 2:
        return OrderFit(note=SINGLE_DT_NOTE)
    return fit_order(group["dt"], group["err_max"], case.error_floor(p),
                     case.error_ceiling(p))
