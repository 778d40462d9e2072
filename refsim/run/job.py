"""One job of the matrix: a case x variant x engine x formulation x integrator x dt, run as
two passes on fresh models. The accuracy pass steps to each sample time, observes and checks
for divergence; the timing pass warms up, then repeats `Sim.step(N)` with nothing observed
and keeps min and median. A failure is a row with a status, never a crash of the sweep.
"""
from __future__ import annotations

import json
import math
import time
import warnings
from dataclasses import asdict, dataclass

import numpy as np

from refsim.engine import IntegratorInfo, jsonable
from refsim.integrators import method_info
from refsim.run.metrics import energy_drift, error_norms
from refsim.options import check_steps
from refsim.run.timing import (BUDGET_S, LONG_RUN_S, build_sim as _build, timing_pass,
                               whole_run_check, whole_run_s)
from refsim.registry import get_case, get_engine
from refsim.verdicts import (INCONSISTENT, NO_REFERENCE, UNRESOLVED, declared_reason,
                             energy_reason, judge, reaches)

STATUSES = ("ok", "diverged", "unsupported", "unavailable", "failed", "timeout")


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
                "tolerance", "diverged_t", "wall_s", "engine_s", "throughput"):
        row[col] = float("nan")
    row.update(repeats=0, timed_steps=0, settings="{}", reaches_target=False, consistency="",
               consistency_reason="", tol_reason="", samples=0, timing="", warnings="")
    return row


def run_job(job: Job, run_id: str = "", repeats: int = 5, budget_s: float = BUDGET_S,
            keep_trajectory: bool = False) -> dict:
    """One row. repeats=0 skips the timing pass; keep_trajectory adds the stacked observations
    under "trajectory" (for tests and plots; never stored in the table)."""
    row = _blank_row(job, run_id)
    repeats = repeats if job.timed else 0
    t0 = time.perf_counter()
    clock = EngineClock()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")  # every warning of the job into its row
        try:
            _run_job(job, row, repeats, budget_s, keep_trajectory, clock)
        except Exception as exc:  # a failure is a row, never a crash of the sweep
            row.update(status="failed", reason=f"{type(exc).__name__}: {exc}".splitlines()[0])
    row.update(wall_s=time.perf_counter() - t0, engine_s=clock.total,
               warnings=warnings_text(caught))
    return row


def warnings_text(caught) -> str:
    """The job's warnings (an engine's own, numpy's on a diverging state) as one line for the
    row's `warnings` column, each distinct one once with its count: never the terminal."""
    counts = {}
    for w in caught:
        text = f"{w.category.__name__}: {str(w.message).splitlines()[0] if str(w.message) else ''}"
        counts[text] = counts.get(text, 0) + 1
    return "; ".join(t + (f" (x{n})" if n > 1 else "") for t, n in counts.items())


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
    stacked = stack_observations(obs)
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
        timing = clock.call(timing_pass, engine, scene, job, steps, timed, repeats, budget_s)
        row.update(whole_run_check(timing, steps, stepping_s, len(obs) - 1,
                                   lambda: clock.call(whole_run_s, engine, scene, job, steps)))
        row["throughput"] = case.bodies(p) * steps / row["step_s"] if row["step_s"] > 0 \
            else float("nan")


def stack_observations(obs: list) -> dict:
    """{name: array over the samples}; a name whose shape changes between samples (a query
    answer: empty before the first step) as an object array of the per-sample arrays."""
    out = {}
    for k in obs[0]:
        values = [np.asarray(o[k]) for o in obs]
        if all(v.shape == values[0].shape for v in values):
            out[k] = np.array(values)
        else:
            out[k] = np.empty(len(values), dtype=object)
            for i, v in enumerate(values):  # one per sample, not per body
                out[k][i] = v
    return out


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
    # its own word, or its energy's behaviour, whatever the bound: not the method it names;
    # and any further condition the case states (a query case's other measures)
    checks = case.consistency_checks(p, {**row, **out}, settings, stacked) \
        if out["consistency"] != UNRESOLVED else []
    for why in (declared_reason(row["declared_order"], method["order"]),
                _energy_behaviour(case, p, method, settings, row, stacked), *checks):
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
    """Energy and the 1-D observables against time, at most SERIES_POINTS samples, and the
    profiles the case's figures declare (`profile_names`) at the last sample: what the report
    plots at the reference dt (the results table keeps only the norms)."""
    t = np.asarray(stacked["t"], float)
    keep = np.unique(np.linspace(0, len(t) - 1, min(len(t), SERIES_POINTS)).astype(int))
    out = {"t": t[keep].tolist()}
    energy = case.energy(p, stacked)
    if energy is not None:
        out["energy"] = np.asarray(energy, float)[keep].tolist()
    profiles = profile_names(case.figures(p))
    for name, values in case.observables(p, stacked).items():
        values = np.asarray(values)
        if name in profiles:
            out[name] = last_profile(name, values, len(t))
        elif values.shape == t.shape and values.dtype.kind in "biuf":  # numbers, one a sample
            out[name] = values.astype(float)[keep].tolist()
    missing = sorted(set(profiles) - set(out))
    if missing:
        raise ValueError(f"{case.name} figures declare the profile {missing[0]!r}, which is not "
                         "one of its observables")
    return out


PROFILE_POINTS = 400  # numbers kept per stored profile, at most


def profile_names(figures) -> list[str]:
    """The observables a case's figures (Case.figures) draw as profiles: each panel's "y" of
    a figure of kind "profile", kept at the last sample by `series`."""
    return [panel["y"] for figure in figures if figure.get("kind") == "profile"
            for panel in figure["panels"]]


def last_profile(name: str, values: np.ndarray, samples: int) -> list[float]:
    """The profile observable `name` (one vector of at most PROFILE_POINTS numbers a sample)
    at the last sample; ValueError naming what is wrong otherwise."""
    if values.ndim != 2 or len(values) != samples or values.shape[1] > PROFILE_POINTS \
            or values.dtype.kind not in "biuf":
        raise ValueError(f"profile {name!r} must be one vector of at most {PROFILE_POINTS} "
                         f"numbers per sample ({samples} samples), got shape {values.shape}")
    return values[-1].astype(float).tolist()


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
