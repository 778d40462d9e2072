"""The error a planted-defect engine (or the control, refsim behind the same wrapper) makes on a
case, in the column the case's tolerance judges, and whether the bound the case gives the NAMED
method catches it: the mechanics the case tests share (tests/cases).

Two ways to run: `job_error` runs the harness's job (`refsim.run.job.run_job`, no timing pass; the
engine is looked up by name, so register the planted engines first: `engines.register_all`),
`defect_error` builds a planted engine's sim directly and samples it as a job does
(`sim_error`). `uncaught` and its two forms `job_uncaught` / `defect_uncaught` list the dts of a
sweep where a wrong run's error does NOT exceed the named method's bound (a test asserts the
list is empty); `bound_misfits` lists those where a correct run is above its own bound or the
bound is loose. The planted defects: an "rk4" that is Heun or Kutta's RK3, a "velocity_verlet"
that is explicit Euler, gravity x 1.001, every pivot arm x 1.005, v *= 1 - 1e-4 a step, ...
(`engines.DEFECTS`)."""
from __future__ import annotations

import numpy as np


def sim_error(case, p, sim, dt) -> float:
    """max over the run's samples of the case's error (err_max) of a built sim at step dt,
    sampled as the job samples (every round(sample_dt / dt) steps)."""
    steps = int(round(case.t_end(p) / dt))
    stride = max(1, int(round(case.sample_dt(p) / dt)))
    frames, done = [sim.observe()], 0
    while done < steps:
        n = min(stride, steps - done)
        sim.step(n)
        done += n
        frames.append(sim.observe())
    sim.close()
    stacked = {k: np.array([f[k] for f in frames]) for k in frames[0]}
    observed, reference = case.observables(p, stacked), case.reference(p, stacked["t"])
    return float(np.max(case.error(p, observed, reference)))


def defect_error(case, p, defect, integrator, dt, formulation="quat_exp") -> float:
    """sim_error of the planted-defect engine `defect` (adapters.planted_defects.DEFECTS
    name, "control" for none) running `integrator` at dt."""
    from refsim_adapters.planted_defects.engines import register_all
    from refsim.registry import get_engine
    register_all()
    sim = get_engine(f"planted_{defect}").build(case.scene(p), dt, integrator, formulation)
    return sim_error(case, p, sim, dt)


def job_error(case_name, variant, engine, integrator, dt, formulation="") -> float:
    """The error of one job of `engine` (a registered name) running `integrator` at dt, in the
    column the case's tolerance judges (`Case.tolerance_column`, usually err_max); fails with
    the row's reason unless the job ran (status ok)."""
    from refsim.run.job import Job, run_job
    from refsim.registry import get_case
    row = run_job(Job(case_name, variant, engine, formulation, integrator, dt), repeats=0)
    assert row["status"] == "ok", row["reason"]
    case = get_case(case_name)
    return row[case.tolerance_column(case.variant_params(variant))]


def sweep(case, p) -> list:
    """Every dt a case's sweep runs at: its timed dts and its order dts, finest first."""
    return sorted(case.dts(p) + case.order_dts(p))


def uncaught(dts, judged, floor=None) -> list:
    """The (dt, error, bound) at which a wrong run's error does NOT exceed the bound: empty
    when the bound catches it at every dt. `judged(dt)` gives (error, bound), or None where
    the run is not judged (e.g. diverged: caught by the run itself); with `floor` (the case's
    error floor) only errors above it are judged."""
    missed = []
    for dt in dts:
        pair = judged(dt)
        if pair is None:
            continue
        error, bound = pair
        if (floor is None or error > floor) and not error > bound:
            missed.append((dt, error, bound))
    return missed


def job_uncaught(case, variant, engine, integrator, order, dts=None, named=None, floor=None,
                 formulation="") -> list:
    """`uncaught` for the jobs (`job_error`) of `engine` running `integrator` at each dt (by
    default the variant's `sweep`), against the bound the case gives the NAMED method
    (`named`, by default `integrator`, of `order`) at that dt."""
    p, named = case.variant_params(variant), named or integrator
    return uncaught(sweep(case, p) if dts is None else dts, lambda dt: (
        job_error(case.name, variant, engine, integrator, dt, formulation),
        case.tolerance(p, named, order, dt, formulation)[0]), floor)


def defect_uncaught(case, p, defect, integrator, order, dts, named=None,
                    formulation="quat_exp") -> list:
    """`uncaught` for the sims (`defect_error`) of the planted engine `defect` running
    `integrator` at each dt, against the bound the case gives the NAMED method (`named`, by
    default `integrator`, of `order`) in that formulation."""
    named = named or integrator
    return uncaught(dts, lambda dt: (
        defect_error(case, p, defect, integrator, dt, formulation),
        case.tolerance(p, named, order, dt, formulation)[0]))


def bound_misfits(case, variant, integrator, dts, within, floor=None, resolved_only=False,
                  engine="refsim") -> list:
    """The (dt, error, bound, reason) at which a correct run (`job_error` of `engine`, the
    in-house one by default) is above the bound the case gives its method (order 0: the case
    takes the method's own), or the bound is above `within` x the error (loose; not judged
    where the error is at or below `floor`, when given). With `resolved_only`, only the dts
    whose bound is below the case's motion scale are run (a bound at the size of the motion
    says nothing)."""
    p, misfits = case.variant_params(variant), []
    for dt in dts:
        bound, reason = case.tolerance(p, integrator, 0, dt)
        if resolved_only and not bound < case.motion_scale(p):
            continue
        error = job_error(case.name, variant, engine, integrator, dt)
        tight = (floor is not None and error <= floor) or bound <= within * error
        if not (error <= bound and tight):
            misfits.append((dt, error, bound, reason))
    return misfits
