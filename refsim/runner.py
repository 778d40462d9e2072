"""Expands the case x engine x integrator x dt matrix and runs it with timing discipline.

Each job is two passes on fresh models: an accuracy pass (step to each sample time, observe,
check for divergence) and a timing pass (warm-up, then `Sim.step(N)` repeated with nothing
observed; min and median kept). A failure is a row with a status, never a crash of the sweep.
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd

from refsim.registry import engine_names, get_engine
from refsim.registry import case_names, get_case
from refsim.engine import IntegratorInfo, jsonable
from refsim.integrators import INTEGRATORS, get_integrator
from refsim.metrics import convergence_order, energy_drift, error_norms

STATUSES = ("ok", "diverged", "unsupported", "unavailable", "failed", "timeout")
LONG_RUN_S = 0.5  # accuracy passes longer than this give the timing sample themselves
BUDGET_S = 0.5  # a timing pass stops repeating once its runs have taken this long


@dataclass(frozen=True)
class Job:
    case: str
    variant: str
    engine: str
    engine_variant: str
    integrator: str
    dt: float
    params: tuple = ()  # case parameter overrides, sorted (name, value) pairs

    @property
    def label(self) -> str:
        eng = self.engine + (f":{self.engine_variant}" if self.engine_variant else "")
        return f"{self.case}/{self.variant} {eng} {self.integrator} dt={self.dt:.3g}"


# ---------------------------------------------------------------------------------------------
# Matrix expansion
# ---------------------------------------------------------------------------------------------
def check_dt(dt) -> float:
    try:
        value = float(dt)
    except (TypeError, ValueError):
        raise ValueError(f"--dt must be a finite number > 0, got {dt!r}") from None
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"--dt must be a finite number > 0, got {dt}")
    return value


def expand(cases=None, engines=None, integrators=None, dts=None, quick=False, variants=None,
           params=None, full=False) -> list[Job]:
    """Every job of the matrix; unknown names raise ValueError naming the valid ones.

    The dt sweep runs each engine's default formulation; its alternatives (the KKT and penalty
    pendulum, taichi's kernel-launch-per-step, MuJoCo's coupled contacts...) compare terms at
    the case's reference dt only (not at all with `quick`), unless `full` (or explicit `dts`)
    asks for the whole sweep."""
    cases = list(cases or case_names())
    for name in cases:
        get_case(name)
    engines = [get_engine(e) for e in (engines or engine_names())]
    dts = [check_dt(d) for d in dts] if dts else None
    if integrators:
        offered = {i for e in engines for i in e.integrators}
        for spec in integrators:
            if spec.partition(":")[0] in INTEGRATORS:
                get_integrator(spec)  # validates a parameter such as rk2:alpha
            if spec.partition(":")[0] not in offered:
                raise ValueError(f"integrator must be one of {sorted(offered)} for engines "
                                 f"{[e.name for e in engines]}, got {spec!r}")
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
            for engine in engines:
                jobs.extend(Job(**{**asdict(j), "params": overrides}) for j in _engine_jobs(
                    cname, variant, engine, scene, integrators, sweep, alt_sweep))
    return jobs


def _variants(case, variants, quick):
    if variants:
        chosen = [v for v in variants if v in case.variants]
        return chosen or [next(iter(case.variants))]
    if quick:
        return list(case.quick_variants)
    return list(case.default_variants or case.variants)


def _engine_jobs(cname, variant, engine, scene, integrators, sweep, alt_sweep):
    if not engine.available() or engine.supports(scene) is not None:
        return [Job(cname, variant, engine.name, "", "", float("nan"))]
    specs = [i for i in (integrators or engine.integrators) if i.partition(":")[0]
             in engine.integrators and engine.supports(scene, i) is None]
    if not specs:  # none of the asked integrators runs this scene: one row says why
        spec = (integrators or engine.integrators)[0]
        return [Job(cname, variant, engine.name, "", spec, float("nan"))]
    forms = engine.variants(scene)
    return [Job(cname, variant, engine.name, ev, spec, dt)
            for k, ev in enumerate(forms) for spec in specs
            for dt in (sweep if k == 0 else alt_sweep)]


# ---------------------------------------------------------------------------------------------
# One job
# ---------------------------------------------------------------------------------------------
def _blank_row(job: Job, run_id: str) -> dict:
    row = {"run_id": run_id, **asdict(job), "params": json.dumps(dict(job.params)),
           "engine_version": "", "steps": 0,
           "t_end": float("nan"), "status": "", "reason": "", "nominal_order": float("nan")}
    for col in ("err_max", "err_final", "err_rms", "energy_drift", "constraint_drift",
                "momentum_drift", "penetration_max", "conservation_err",
                "setup_s", "compile_s", "step_s", "step_s_median", "us_per_step",
                "tolerance", "diverged_t", "wall_s", "engine_s"):
        row[col] = float("nan")
    row.update(repeats=0, settings="{}", within_tol=False, tol_capped=False, tol_reason="",
               samples=0, timing="")
    return row


def run_job(job: Job, run_id: str = "", repeats: int = 3, budget_s: float = BUDGET_S,
            keep_trajectory: bool = False) -> dict:
    """One row. repeats=0 skips the timing pass; keep_trajectory adds the stacked observations
    under "trajectory" (for tests and plots; never stored in the table)."""
    row = _blank_row(job, run_id)
    t0 = time.perf_counter()
    clock = EngineClock()
    try:
        _run_job(job, row, repeats, budget_s, keep_trajectory, clock)
    except Exception as exc:  # a failure is a row, never a crash of the sweep
        row.update(status="failed", reason=f"{type(exc).__name__}: {exc}".splitlines()[0])
    row.update(wall_s=time.perf_counter() - t0, engine_s=clock.total)
    return row


class EngineClock:
    """Time spent inside engine calls (build, step, observe, close) in both passes: the rest
    of a row's wall time is the harness's own (references, metrics, checks, storage)."""

    def __init__(self):
        self.total = 0.0

    def call(self, fn, *args):
        t0 = time.perf_counter()
        try:
            return fn(*args)
        finally:
            self.total += time.perf_counter() - t0


def _run_job(job, row, repeats, budget_s, keep_trajectory, clock):
    case, engine = get_case(job.case), get_engine(job.engine)
    p = case.variant_params(job.variant, dict(job.params))
    scene = case.scene(p)
    if not engine.available():
        row.update(status="unavailable", reason=f"{engine.package} is not installed")
        return
    row["engine_version"] = engine.version()
    reason = engine.supports(scene, job.integrator or None)
    if reason is not None:
        row.update(status="unsupported", reason=reason)
        return
    steps = int(round(case.t_end(p) / job.dt))
    stride = max(1, int(round(case.sample_dt(p) / job.dt)))
    row.update(steps=steps, t_end=steps * job.dt)
    sim, setup_s = clock.call(_build, engine, scene, job)
    row.update(setup_s=setup_s, compile_s=sim.compile_s,
               settings=json.dumps(jsonable(sim.settings())), nominal_order=_nominal_order(sim, job))
    obs, diverged, stepping_s = _accuracy_pass(case, p, sim, steps, stride, clock)
    clock.call(sim.close)
    stacked = {k: np.array([o[k] for o in obs]) for k in obs[0]}
    if diverged:
        row.update(status="diverged", reason=diverged[0], diverged_t=diverged[1],
                   samples=len(obs))
        return
    row.update(_accuracy_metrics(case, p, stacked), status="ok", samples=len(obs))
    if keep_trajectory:
        row["trajectory"] = stacked
    if math.isclose(job.dt, case.reference_dt(p), rel_tol=1e-9):
        row["series"] = series(case, p, stacked)
    tol, why = case.tolerance(p, job.integrator, row["nominal_order"], job.dt,
                              job.engine_variant, json.loads(row["settings"]))
    row["tol_capped"] = bool(tol >= case.motion_scale(p))
    if row["tol_capped"]:  # a bound larger than the motion would accept any answer
        tol, why = case.motion_scale(p), (f"{why}; that bound ({tol:.3g}) exceeds the motion "
                                          f"itself: capped at the motion scale (this dt does "
                                          f"not resolve the case with this method)")
    row.update(tolerance=tol, tol_reason=why,
               within_tol=bool(row[case.tolerance_column(p)] <= tol))
    if repeats > 0 and stepping_s > max(budget_s, LONG_RUN_S):
        # a long run: its step() calls in the accuracy pass (observation outside them) are
        # the one timing sample; repeating it would only double the wall time. Its <= ~400
        # calls cost ~30 us each at most in per-call overhead (a taichi launch, ENGINE_NOTES):
        # <= 12 ms, < 2.5 % of a run this long
        row.update(step_s=stepping_s, step_s_median=stepping_s, repeats=1,
                   us_per_step=stepping_s / steps * 1e6, timing="accuracy-pass step calls")
    elif repeats > 0:  # repeats=0: accuracy pass only (tests, convergence studies)
        row.update(clock.call(_timing_pass, engine, scene, job, steps, repeats, budget_s),
                   timing="fresh models, min of repeats")


def _build(engine, scene, job):
    t0 = time.perf_counter()
    sim = engine.build(scene, job.dt, job.integrator, job.engine_variant)
    return sim, time.perf_counter() - t0 - sim.compile_s


def _nominal_order(sim, job):
    described = IntegratorInfo.of(sim.settings())
    if described is not None:
        return float(described.order)
    try:
        return float(get_integrator(job.integrator).order)
    except ValueError:
        return float("nan")


def _accuracy_pass(case, p, sim, steps, stride, clock):
    """Observe at t = 0 and every `stride` steps; stop at the first sign of divergence.
    Returns the observations, the divergence (reason, t) or None, and the time spent inside
    `Sim.step` calls only."""
    obs = [clock.call(sim.observe)]
    e_scale = case.energy_scale(p)
    done, stepping = 0, 0.0
    while done < steps:
        n = min(stride, steps - done)
        t0 = time.perf_counter()
        sim.step(n)
        stepping += time.perf_counter() - t0
        done += n
        o = clock.call(sim.observe)
        obs.append(o)
        why = _divergence(case, p, sim, o, obs[0], e_scale)
        if why:
            clock.total += stepping
            return obs, (f"{why} at t={o['t']:.6g} s", o["t"]), stepping
    clock.total += stepping
    return obs, None, stepping


SERIES_POINTS = 400  # samples kept per stored time series (for the report's plots)


def series(case, p, stacked) -> dict:
    """Energy and the 1-D observables against time, at most SERIES_POINTS samples: what the
    report plots at the reference dt (the results table keeps only the norms)."""
    t = np.asarray(stacked["t"], float)
    keep = np.unique(np.linspace(0, len(t) - 1, min(len(t), SERIES_POINTS)).astype(int))
    out = {"t": t[keep].tolist()}
    energy = case.energy(p, stacked)
    if energy is not None:
        out["energy"] = np.asarray(energy, float)[keep].tolist()
    for name, values in case.observables(p, stacked).items():
        values = np.asarray(values, float)
        if values.shape == t.shape:
            out[name] = values[keep].tolist()
    return out


def _divergence(case, p, sim, o, first, e_scale):
    if sim.failure:
        return sim.failure
    if not (np.all(np.isfinite(o["x"])) and np.all(np.isfinite(o["v"]))):
        return "non-finite state"
    stacked = {k: np.asarray([o[k]]) for k in o}
    energy = case.energy(p, stacked)
    if energy is not None:
        e0 = case.energy(p, {k: np.asarray([first[k]]) for k in first})[0]
        if abs(energy[0] - e0) > case.divergence_factor * e_scale:
            return f"energy beyond {case.divergence_factor:g} x the energy scale"
    return None


def _accuracy_metrics(case, p, stacked):
    observed = case.observables(p, stacked)
    reference = case.reference(p, stacked["t"])
    out = error_norms(case.error(p, observed, reference))
    energy = case.energy(p, stacked)
    ref_energy = (case.reference_energy(p, stacked["t"]) if hasattr(case, "reference_energy")
                  else None)
    if energy is not None:
        ref = np.full(len(energy), energy[0]) if ref_energy is None else ref_energy
        mask = (case.energy_mask(p, stacked["t"]) if hasattr(case, "energy_mask")
                else np.ones(len(energy), bool))
        out["energy_drift"] = energy_drift(energy[mask], ref[mask], case.energy_scale(p))
    if "constraint" in observed:
        out["constraint_drift"] = float(np.max(np.abs(observed["constraint"])))
    out.update(case.extra_metrics(p, stacked, observed, reference))
    return out


def _timing_pass(engine, scene, job, steps, repeats, budget_s):
    """`repeats` fresh models each stepped N times (within a time budget, at least once),
    nothing observed inside the timed region. The accuracy pass just ran the same code on the
    same scene and step: it is the warm-up (compilation, caches, lazy imports)."""
    times, setups, spent = [], [], 0.0
    while len(times) < max(1, repeats) and (not times or spent < budget_s):
        sim, setup_s = _build(engine, scene, job)
        t0 = time.perf_counter()
        sim.step(steps)
        times.append(time.perf_counter() - t0)
        sim.close()
        setups.append(setup_s)
        spent += times[-1] + setup_s
    best = min(times)
    return {"step_s": best, "step_s_median": float(np.median(times)),
            "us_per_step": best / steps * 1e6, "repeats": len(times),
            "setup_s": min(setups)}


# ---------------------------------------------------------------------------------------------
# The matrix
# ---------------------------------------------------------------------------------------------
def run_matrix(jobs, store, repeats=3, budget_s=BUDGET_S, progress=None,
               workers=1) -> pd.DataFrame:
    """Runs every job not yet in `store`, `workers` at a time (separate processes, each on
    one BLAS/taichi thread), storing each row as it arrives; rows keep the jobs' order.
    Leaves on the store `harness_s` (time outside engine calls, in the jobs and in this
    process between them) and `busy_s` (all the time spent on the jobs, summed over
    workers): the harness overhead is their ratio."""
    from refsim.store import row_key
    run_id = store.dir.name
    done = store.done_keys()
    todo = [j for j in jobs if row_key(asdict(j)) not in done]
    order = {row_key(asdict(j)): k for k, j in enumerate(jobs)}
    start, waited, fresh = time.perf_counter(), 0.0, []
    results = _results(todo, run_id, repeats, budget_s, workers)
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
    if progress:
        progress(len(todo), len(todo), None)
    store.rows.sort(key=lambda r: order.get(row_key(r), len(order)))
    table = with_orders(pd.DataFrame(store.rows))
    store.write_table(table)
    parent_s = time.perf_counter() - start - waited
    store.harness_s = parent_s + float(sum(r["wall_s"] - r["engine_s"] for r in fresh))
    store.busy_s = parent_s + float(sum(r["wall_s"] for r in fresh))
    return table


def _work(args):
    job, run_id, repeats, budget_s = args
    return job, run_job(job, run_id, repeats, budget_s)


def _results(todo, run_id, repeats, budget_s, workers):
    """(job, row) pairs: in order on one worker; as they finish on several, the longest
    jobs (fluids) first so that none is left running alone at the end."""
    tasks = [(j, run_id, repeats, budget_s) for j in todo]
    if workers <= 1 or len(todo) <= 1:
        yield from map(_work, tasks)
        return
    import multiprocessing as mp
    tasks.sort(key=lambda t: -_job_size(t[0]))
    with mp.get_context("spawn").Pool(workers, initializer=_worker_init) as pool:
        yield from pool.imap_unordered(_work, tasks, chunksize=1)


def _job_size(job) -> float:
    """A job's work (its case's estimate, Case.work), to start the largest runs first; 0 for
    an engine that does not support the case (no dt: nothing runs)."""
    if not job.dt == job.dt:
        return 0.0
    case = get_case(job.case)
    return case.work(case.variant_params(job.variant, dict(job.params)), job.dt)


def _worker_init():
    import os
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"


GROUP = ["case", "variant", "engine", "engine_variant", "integrator"]


def with_orders(table: pd.DataFrame) -> pd.DataFrame:
    """Adds `order`: the measured convergence order of each case x engine x integrator."""
    table = table.copy()
    table["order"] = np.nan
    table["order_points"] = 0
    for key, group in table[table["status"] == "ok"].groupby(GROUP + ["params"], dropna=False):
        case = get_case(key[0])
        if not case.order_meaningful:
            continue
        p = case.variant_params(key[1], json.loads(key[-1]))
        floor, ceiling = case.error_floor(p), case.error_ceiling(p)
        order, used = convergence_order(group["dt"], group["err_max"], floor, ceiling)
        table.loc[group.index, "order"] = order
        table.loc[group.index, "order_points"] = used
    return table
