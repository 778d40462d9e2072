"""One job of the matrix: a case x variant x engine x formulation x integrator x dt, run as
two passes on fresh models. The accuracy pass steps to each sample time, observes and checks
for divergence; the timing pass warms up, then repeats `Sim.step(N)` with nothing observed
and keeps min and median. A failure is a row with a status, never a crash of the sweep.
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, dataclass

import numpy as np

from refsim.engine import IntegratorInfo, jsonable
from refsim.integrators import get_integrator
from refsim.metrics import energy_drift, error_norms
from refsim.registry import get_case, get_engine

STATUSES = ("ok", "diverged", "unsupported", "unavailable", "failed", "timeout")
# Accuracy passes longer than LONG_RUN_S give the timing sample themselves; a timing pass stops
# repeating once its runs have taken BUDGET_S. At 0.5 s both, timing took 207 s of the default
# run's 780 s of work (2,107 rows); at 0.2 s, 100 s (computed from that run's own rows). What
# a repeat buys, the min of 3 instead of 2 for a 0.07-0.2 s row, is within the spread of a
# shared 2-core machine; a per-call overhead inside a 0.2 s accuracy pass is <= 400 calls of
# ~30 us (a taichi launch): 6 % at most, for taichi rows only (see _run_job).
LONG_RUN_S = 0.2
BUDGET_S = 0.2


@dataclass(frozen=True)
class Job:
    case: str
    variant: str
    engine: str
    engine_variant: str
    integrator: str
    dt: float
    params: tuple = ()  # case parameter overrides, sorted (name, value) pairs
    timed: bool = True  # False: accuracy pass only (a case's order_dts, for the order fit)

    @property
    def label(self) -> str:
        eng = self.engine + (f":{self.engine_variant}" if self.engine_variant else "")
        return f"{self.case}/{self.variant} {eng} {self.integrator} dt={self.dt:.3g}"



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
    row.update(repeats=0, settings="{}", within_tol=False, tol_capped=False, unresolved=False,
               tol_reason="", samples=0, timing="")
    return row


def run_job(job: Job, run_id: str = "", repeats: int = 3, budget_s: float = BUDGET_S,
            keep_trajectory: bool = False) -> dict:
    """One row. repeats=0 skips the timing pass; keep_trajectory adds the stacked observations
    under "trajectory" (for tests and plots; never stored in the table)."""
    row = _blank_row(job, run_id)
    repeats = repeats if job.timed else 0
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
    if steps < 1:  # expand() refuses it; a Job built by hand gets a row saying why
        raise ValueError(f"dt = {job.dt:g} s is longer than the run (t_end = "
                         f"{case.t_end(p):g} s): dt must be in (0, {case.t_end(p):g}] s")
    stride = max(1, int(round(case.sample_dt(p) / job.dt)))
    row.update(steps=steps, t_end=steps * job.dt)
    sim, setup_s = clock.call(_build, engine, scene, job)
    row.update(setup_s=setup_s, compile_s=sim.compile_s,
               settings=json.dumps(jsonable(sim.settings())),
               nominal_order=_nominal_order(sim, job))
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
    row.update(_verdict(case, p, job, row))
    if repeats > 0 and stepping_s > max(budget_s, LONG_RUN_S):
        # a long run: its step() calls in the accuracy pass (observation outside them) are
        # the one timing sample; repeating it would only double the wall time. Its <= ~400
        # calls cost ~30 us each at most in per-call overhead (a taichi launch, ENGINE_NOTES):
        # <= 12 ms, <= 6 % of a run this long
        row.update(step_s=stepping_s, step_s_median=stepping_s, repeats=1,
                   us_per_step=stepping_s / steps * 1e6, timing="accuracy-pass step calls")
    elif repeats > 0:  # repeats=0: accuracy pass only (tests, convergence studies)
        row.update(clock.call(_timing_pass, engine, scene, job, steps, repeats, budget_s),
                   timing="fresh models, min of repeats")


def _verdict(case, p, job, row) -> dict:
    """tolerance, tol_reason, within_tol and unresolved of an ok row. A derived bound at or
    above the motion itself would accept any answer (a spring damped out entirely errs by less
    than its amplitude): such a row is `unresolved` (this dt does not resolve the case with
    this method), never within tolerance; its tolerance column keeps the motion scale."""
    tol, why = case.tolerance(p, job.integrator, row["nominal_order"], job.dt,
                              job.engine_variant, json.loads(row["settings"]))
    scale = case.motion_scale(p)
    if tol >= scale:
        return {"tolerance": scale, "tol_capped": True, "unresolved": True, "within_tol": False,
                "tol_reason": f"{why}; that bound ({tol:.3g}) is not below the motion itself "
                              f"({scale:.3g}): unresolved, no accuracy verdict at this dt"}
    return {"tolerance": tol, "tol_reason": why, "tol_capped": False, "unresolved": False,
            "within_tol": bool(row[case.tolerance_column(p)] <= tol)}


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


ENERGY_BATCH = 16  # observations whose energies the divergence check evaluates together


def _accuracy_pass(case, p, sim, steps, stride, clock):
    """Observe at t = 0 and every `stride` steps; stop at the first sign of divergence.
    Returns the observations, the divergence (reason, t) or None, and the time spent inside
    `Sim.step` calls only.

    The engine's failure and a non-finite state are checked at every observation; the energy
    criterion for ENERGY_BATCH observations at once (one vectorised `case.energy` call, not
    one per observation: a fifth of a short row's time). The verdict is the same as checking
    each observation in turn: the first observation that fails any criterion ends the
    observations and names the reason; only the engine may have stepped up to ENERGY_BATCH - 1
    observations past it."""
    obs = [clock.call(sim.observe)]
    e_scale = case.energy_scale(p)
    e0 = _energy_at(case, p, obs[0])  # once: every later observation is compared with it
    done, stepping, pending = 0, 0.0, 1  # obs[pending:]: energies not yet checked
    while done < steps:
        n = min(stride, steps - done)
        t0 = time.perf_counter()
        sim.step(n)
        stepping += time.perf_counter() - t0
        done += n
        obs.append(clock.call(sim.observe))
        why = _state_failure(sim, obs[-1])
        last = len(obs) - (1 if why else 0)  # a failed observation's energy is not asked
        if e0 is not None and (why or done >= steps or last - pending >= ENERGY_BATCH):
            k = _first_energy_divergence(case, p, obs, pending, last, e0, e_scale)
            pending = last
            if k is not None:
                del obs[k + 1:]
                why = f"energy beyond {case.divergence_factor:g} x the energy scale"
        if why:
            clock.total += stepping
            return obs, (f"{why} at t={obs[-1]['t']:.6g} s", obs[-1]["t"]), stepping
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


def _energy_at(case, p, o):
    """The case's energy of one observation (None when the case defines none)."""
    energy = case.energy(p, {k: np.asarray([o[k]]) for k in o})
    return None if energy is None else energy[0]


def _state_failure(sim, o):
    """The engine's own failure, or a non-finite state at observation `o`; None when neither."""
    if sim.failure:
        return sim.failure
    state = [name for name in o if name in ("x", "v") or name.startswith("grid.")]
    if not all(np.isfinite(o[name]).all() for name in state):
        return "non-finite state"
    return None


def _first_energy_divergence(case, p, obs, start, stop, e0, e_scale):
    """Index of the first of obs[start:stop] whose energy is past `divergence_factor` energy
    scales from e0, or None."""
    if stop <= start:
        return None
    batch = obs[start:stop]
    with np.errstate(all="ignore"):  # a diverging state may overflow: it is judged, not run
        energy = np.asarray(case.energy(p, {k: np.asarray([o[k] for o in batch])
                                            for k in batch[0]}), float)
        beyond = np.flatnonzero(np.abs(energy - e0) > case.divergence_factor * e_scale)
    return None if len(beyond) == 0 else start + int(beyond[0])


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
