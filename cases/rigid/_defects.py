"""Planted-defect checks of the rigid cases' bounds (used by their tests): the error a sim makes
on a case, in the case's tolerance column, and the planted-defect engines' sims
(`adapters.planted_defects`: an "rk4" that is Heun or Kutta's RK3, gravity x 1.001, every
pivot arm x 1.005, v *= 1 - 1e-4 a step), so that a test compares a wrong run's error with the
bound the case gives the NAMED method."""
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
    from adapters.planted_defects.engines import register_all
    from refsim.registry import get_engine
    register_all()
    sim = get_engine(f"planted_{defect}").build(case.scene(p), dt, integrator, formulation)
    return sim_error(case, p, sim, dt)
