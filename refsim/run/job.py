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
from refsim.integrators import method_info
from refsim.run.metrics import energy_drift, error_norms
from refsim.options import check_steps
from refsim.registry import get_case, get_engine
from refsim.verdicts import (INCONSISTENT, NO_REFERENCE, UNRESOLVED, declared_reason,
                             energy_reason, judge, reaches)

STATUSES = ("ok", "diverged", "unsupported", "unavailable", "failed", "timeout")
# The timing pass steps fresh models with nothing observed, repeating until the figure is
# stable (see _timing_pass). A run whose accuracy pass spent over LONG_RUN_S inside step calls
# is timed over its first N' steps only, N' chosen so that one timed run takes about
# LONG_RUN_S, and scaled to the whole run (`timed_steps` says N'); the accuracy pass never
# gives the timing sample (its step calls are one per observation: a taichi kernel launch
# each, 0.4 ms against 0.9 us per step inside one launch, measured on newtons_cradle).
# 0.1 s a timed run: the scheduler's jitter (a few ms a second on a quiet 2-core machine) is a
# few per cent of it, below the spread at which repeats stop.
LONG_RUN_S = 0.1
# Repeats stop once the median of the timed runs is within TIMING_SPREAD of their min (at
# least two runs), or past BUDGET_S of timed runs while unsettled (`timing` says so).
TIMING_SPREAD = 0.05
BUDGET_S = 0.5
PROBES = 4  # probe calls at most to size N' (each grows it by LONG_RUN_S / its time)
# a run whose 1-step call takes over this share of its whole call is call-dominated, said
# in `timing`: its us_per_step is mostly the call's fixed cost (taichi newtons_cradle: a
# 400-800 us launch and sync, +-300 us, against 125-700 us of steps in the whole run)
CALL_DOMINATED = 0.5


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
           "t_end": float("nan"), "status": "", "reason": "", "nominal_order": float("nan"),
           "declared_order": float("nan")}
    for col in ("err_max", "err_final", "err_rms", "err_initial", "energy_drift",
                "constraint_drift", "target_error",
                "momentum_drift", "penetration_max", "conservation_err",
                "setup_s", "compile_s", "step_s", "step_s_median", "us_per_step", "call_us",
                "tolerance", "diverged_t", "wall_s", "engine_s"):
        row[col] = float("nan")
    row.update(repeats=0, timed_steps=0, settings="{}", reaches_target=False, consistency="",
               consistency_reason="", tol_reason="", samples=0, timing="")
    return row


def run_job(job: Job, run_id: str = "", repeats: int = 5, budget_s: float = BUDGET_S,
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
    # expand() refuses a dt longer than the run; a Job built by hand gets a row saying why
    steps = check_steps(job.dt, case.t_end(p), f"{job.case}/{job.variant}", math.inf)
    stride = max(1, int(round(case.sample_dt(p) / job.dt)))
    row.update(steps=steps, t_end=steps * job.dt)
    sim, setup_s = clock.call(_build, engine, scene, job)
    row.update(setup_s=setup_s, compile_s=sim.compile_s,
               settings=json.dumps(jsonable(sim.settings())),
               nominal_order=_nominal_order(job), declared_order=_declared_order(sim))
    obs, stopped, stepping_s = _accuracy_pass(case, p, sim, steps, stride, clock)
    clock.call(sim.close)
    stacked = {k: np.array([o[k] for o in obs]) for k in obs[0]}
    if stopped:
        status, why, t_stop = stopped
        row.update(status=status, reason=why, diverged_t=t_stop, samples=len(obs))
        return
    row.update(_accuracy_metrics(case, p, stacked), status="ok", samples=len(obs))
    if keep_trajectory:
        row["trajectory"] = stacked
    if math.isclose(job.dt, case.reference_dt(p), rel_tol=1e-9):
        row["series"] = series(case, p, stacked)
    row.update(_verdicts(case, p, job, row, stacked))
    if repeats > 0:  # repeats=0: accuracy pass only (tests, convergence studies)
        timed = steps if stepping_s <= LONG_RUN_S else max(
            1, min(steps, int(steps * LONG_RUN_S / stepping_s)))
        row.update(clock.call(_timing_pass, engine, scene, job, steps, timed, repeats,
                              budget_s))


def _verdicts(case, p, job, row, stacked) -> dict:
    """reaches_target (the case's target) and consistency with the NAMED method (its bound from
    the case for that method, whatever the engine declares; for a symplectic method on a
    conservative scene, also its bounded energy; see refsim.verdicts)."""
    column = case.tolerance_column(p)
    target = case.target_error(p)
    out = {"target_error": target, "reaches_target": reaches(row[column], target)}
    method = method_info(job.integrator)
    if method is None:
        return {**out, "tolerance": float("nan"), "consistency": NO_REFERENCE,
                "tol_reason": f"{job.integrator!r} is {job.engine}'s own scheme, not a method "
                              "refsim defines: no method bound, only the target question",
                "consistency_reason": ""}
    settings = {**json.loads(row["settings"]), "integrator": method}
    bound, why = case.tolerance(p, job.integrator, method["order"], job.dt,
                                job.engine_variant, settings)
    initial = row["err_initial"] if case.initial_state_is_reference else float("nan")
    out.update(judge(row[column], bound, why, case.motion_scale(p), initial,
                     case.error_floor(p)))
    # its own word, or its energy's behaviour, whatever the bound: not the method it names
    for why in (declared_reason(row["declared_order"], method["order"]),
                _energy_behaviour(case, p, method, settings, row, stacked)):
        if why is not None:
            earlier = "" if out["consistency"] == UNRESOLVED else out["consistency_reason"]
            out.update(consistency=INCONSISTENT,
                       consistency_reason="; ".join(r for r in (earlier, why) if r))
    return out


def _energy_behaviour(case, p, method, settings, row, stacked) -> str | None:
    """energy_reason for a symplectic method on a case whose flow conserves energy."""
    if not method["symplectic"]:
        return None
    period = case.energy_period(p, settings)
    energy = None if period is None else case.energy(p, stacked)
    if energy is None:
        return None
    e_scale = max(abs(float(energy[0])), case.energy_scale(p))
    return energy_reason(stacked["t"], energy, e_scale, period, row["steps"])


def _build(engine, scene, job):
    t0 = time.perf_counter()
    sim = engine.build(scene, job.dt, job.integrator, job.engine_variant)
    return sim, time.perf_counter() - t0 - sim.compile_s


def _nominal_order(job):
    """The order of the method the integrator names (NaN for an engine's own scheme)."""
    method = method_info(job.integrator)
    return float("nan") if method is None else method["order"]


def _declared_order(sim):
    """The order the engine declares for its stepper in its settings (NaN if it declares none):
    shown beside the verdict, never used for it."""
    described = IntegratorInfo.of(sim.settings())
    return float("nan") if described is None else float(described.order)


ENERGY_BATCH = 16  # observations whose energies the divergence check evaluates together


def _accuracy_pass(case, p, sim, steps, stride, clock):
    """Observe at t = 0 and every `stride` steps; stop at the first sign of a breakdown.
    Returns the observations, (status, reason, t) of the stop or None, and the time spent
    inside `Sim.step` calls only.

    `diverged` means unbounded: a non-finite state, or an energy that has GROWN past
    `divergence_factor` times the initial state's own energy scale (max(|E0|, the case's
    energy scale)); a decaying or settling run never is. An engine's own failure with a
    bounded, finite state (a solver that did not converge, a full buffer) is `failed`, named
    by the engine's message. The state is checked at every observation, the energy for
    ENERGY_BATCH observations at once (one vectorised `case.energy` call): the first
    observation that fails ends the observations; only the engine may have stepped up to
    ENERGY_BATCH - 1 observations past it."""
    obs = [clock.call(sim.observe)]
    e0 = _energy_at(case, p, obs[0])  # once: every later observation is compared with it
    e_scale = None if e0 is None else max(abs(float(e0)), case.energy_scale(p))
    done, stepping, pending = 0, 0.0, 1  # obs[pending:]: energies not yet checked
    while done < steps:
        n = min(stride, steps - done)
        t0 = time.perf_counter()
        sim.step(n)
        stepping += time.perf_counter() - t0
        done += n
        obs.append(clock.call(sim.observe))
        stop = _state_failure(sim, obs[-1])
        last = len(obs) - (1 if stop and stop[0] == "diverged" else 0)
        if e0 is not None and (stop or done >= steps or last - pending >= ENERGY_BATCH):
            k = _first_energy_growth(case, p, obs, pending, last, e0, e_scale)
            pending = last
            if k is not None:
                del obs[k + 1:]
                stop = ("diverged", f"energy grew past {case.divergence_factor:g} x the "
                                    f"initial energy scale {e_scale:.3g}"
                        + (f" ({sim.failure})" if sim.failure else ""))
        if stop:
            clock.total += stepping
            t_stop = float(obs[-1]["t"])
            why = stop[1] if "t=" in stop[1] else f"{stop[1]} at t={t_stop:.6g} s"
            return obs, (stop[0], why, t_stop), stepping
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
    """("diverged", why) for a non-finite state, ("failed", why) for the engine's own failure
    with a finite state (its energy is judged next), None when neither."""
    state = [name for name in o if name in ("x", "v") or name.startswith("grid.")]
    if not all(np.isfinite(o[name]).all() for name in state):
        return "diverged", "non-finite state" + (f" ({sim.failure})" if sim.failure else "")
    if sim.failure:
        return "failed", sim.failure
    return None


def _first_energy_growth(case, p, obs, start, stop, e0, e_scale):
    """Index of the first of obs[start:stop] whose energy has grown past `divergence_factor`
    times `e_scale` above e0 (one-sided: energy lost is never divergence), or None."""
    if stop <= start:
        return None
    batch = obs[start:stop]
    with np.errstate(all="ignore"):  # a diverging state may overflow: it is judged, not run
        energy = np.asarray(case.energy(p, {k: np.asarray([o[k] for o in batch])
                                            for k in batch[0]}), float)
        grown = np.flatnonzero(~(energy - e0 <= case.divergence_factor * e_scale))
    return None if len(grown) == 0 else start + int(grown[0])


def _accuracy_metrics(case, p, stacked):
    observed = case.observables(p, stacked)
    reference = case.reference(p, stacked["t"])
    err = case.error(p, observed, reference)
    out = error_norms(err)
    out["err_initial"] = float(np.asarray(err, float)[0])
    energy = case.energy(p, stacked)
    ref_energy = case.reference_energy(p, stacked["t"])
    if energy is not None:
        ref = np.full(len(energy), energy[0]) if ref_energy is None else ref_energy
        mask = case.energy_mask(p, stacked["t"])
        mask = np.ones(len(energy), bool) if mask is None else mask
        out["energy_drift"] = energy_drift(energy[mask], ref[mask], case.energy_scale(p))
    if "constraint" in observed:
        out["constraint_drift"] = float(np.max(np.abs(observed["constraint"])))
    out.update(case.extra_metrics(p, stacked, observed, reference))
    return out


def _timing_pass(engine, scene, job, steps, timed, repeats, budget_s):
    """Fresh models each stepped `timed` steps in one call, nothing observed inside the timed
    region, and as many fresh models stepped one step in one call (`call_us`: the fixed cost
    of a call, e.g. a kernel launch and sync). us_per_step is what a step costs when the run
    is stepped in one call, the call's fixed cost included (min over the fresh models / N'):
    the engine's real cost of the run, never the harness's. A call-dominated run (its 1-step
    call over CALL_DOMINATED of the whole call) says so in `timing`; its marginal per-step cost
    is below the call's jitter. A run of `steps` is scaled from its first `timed` steps. The
    accuracy pass just ran the same code on the same scene and step: it is the warm-up
    (compilation, caches, lazy imports).

    Repeats stop when the figure is stable: at least min(2, `repeats`) timed runs, then more
    (up to `repeats`) only while the median is over TIMING_SPREAD above the min and the timed
    runs have taken less than `budget_s`; `timing` gives the count and the spread, and says
    `unsettled` when it stopped above it. The probe that sized N' is itself the first timed
    run when its N is the final one."""
    timed, times = _probe_stretch(engine, scene, job, steps, timed)
    ones, setups, spent = [], [], sum(times)
    least = min(2, max(1, repeats))
    while len(times) < max(1, repeats) and not (
            len(times) >= least and (_spread(times) <= TIMING_SPREAD or spent >= budget_s)):
        sim, setup_s = _build(engine, scene, job)
        t0 = time.perf_counter()
        sim.step(timed)
        times.append(time.perf_counter() - t0)
        sim.close()
        setups.append(setup_s)
        spent += times[-1]
    while len(ones) < len(times):
        sim, setup_s = _build(engine, scene, job)
        t0 = time.perf_counter()
        sim.step(1)
        ones.append(time.perf_counter() - t0)
        sim.close()
        setups.append(setup_s)
    best, call, spread = min(times), min(ones), _spread(times)
    scale = steps / timed
    stretch = "" if timed == steps else f", first {timed} of {steps} steps, scaled"
    settled = ("" if len(times) < 2 else f", median {100 * spread:.2g} % above it" + (
        "" if spread <= TIMING_SPREAD else " (unsettled)"))
    dominated = (f"; call-dominated: a 1-step call takes {call * 1e6:.3g} us of its "
                 f"{best * 1e6:.3g} us" if timed > 1 and call > CALL_DOMINATED * best else "")
    return {"step_s": best * scale, "step_s_median": float(np.median(times)) * scale,
            "us_per_step": best / timed * 1e6, "call_us": call * 1e6, "repeats": len(times),
            "timed_steps": timed, "setup_s": min(setups),
            "timing": f"fresh models, min of {len(times)}{settled}{stretch}{dominated}"}


def _spread(times) -> float:
    """(median - min) / min of the timed runs (0 for one run)."""
    best = min(times)
    return float(np.median(times)) / best - 1.0 if best > 0 else 0.0


def _probe_stretch(engine, scene, job, steps, timed):
    """N' came from the accuracy pass, whose per-observation calls (a kernel launch each) may
    dwarf the stepping: probe calls of N' steps, N' grown to what fits LONG_RUN_S by each
    measure (the whole run when it fits), at most PROBES of them. Returns N' and the probe's
    time as the first timed run when the last probe ran the final N' ([] otherwise)."""
    for _ in range(PROBES):
        sim, _ = _build(engine, scene, job)
        t0 = time.perf_counter()
        sim.step(timed)
        probe = time.perf_counter() - t0
        sim.close()
        if timed >= steps or probe >= LONG_RUN_S / 4:
            return timed, [probe]
        timed = min(steps, int(timed * LONG_RUN_S / max(probe, 1e-9)))
    return timed, []
