"""The emitter group (the slide's sprinkler, cases/emitter/sprinkler.py) on every engine
that runs it: refsim (refsim/models/emitter.py) and taichi (its emitter kernels). Every live
particle lies on the exact discrete parabola of its stepper from its spawn state (to
round-off), with the births on the step grid of the formulation, per stepper and formulation;
an engine that re-implements refsim's group also gives the same ids, births, counts and states
as refsim's, slot for slot. Per-engine data in EMITTERS, with its reason; counts and refusals of
each engine stay in its own files (tests/engines/refsim/test_refsim_flocking.py,
tests/engines/taichi/test_taichi_emitter.py). A missing engine package fails its parameters,
never skips them (installed_engines.py).
"""
import numpy as np
import pytest
from emitter_runs import EMITTER, run
from installed_engines import installed

from refsim.models import emitter as em

P = EMITTER.variant_params("default")
# Per engine: (steppers, dts, Sim.step lengths, the engine whose run it must equal).
EMITTERS = {
    # every stepper refsim offers the group; observed every 10 steps over the case's 1 s
    "refsim": (("explicit_euler", "symplectic_euler", "symplectic_euler_dk", "rk4",
                "stormer_verlet", "leapfrog", "velocity_verlet", "heun"), (0.01,),
               (10,) * 10, None),
    # the steppers taichi's kernels offer, at each of the case's dts; chunks of odd lengths put
    # births mid-launch and at its end; the same arithmetic as refsim's group (its tableau in
    # the same order): equal to refsim's run to round-off (measured: bit for bit)
    "taichi": (("symplectic_euler", "velocity_verlet", "rk4", "explicit_euler", "midpoint"),
               tuple(EMITTER.dts(P)), (1, 2, 3, 7, 10, 13, 1, 40), "refsim"),
}


@pytest.mark.parametrize("formulation", ["corrected", "as_printed"])
@pytest.mark.parametrize("engine,integrator,dt", [
    pytest.param(engine, integrator, dt, id=f"{engine}-{integrator}-{dt:g}")
    for engine, (steppers, dts, _, _) in EMITTERS.items() for integrator in steppers
    for dt in dts])
def test_every_particle_on_its_exact_discrete_path(engine, integrator, dt, formulation):
    _, _, chunks, same_as = EMITTERS[engine]
    installed(engine)
    obs, settings = run(engine, P, integrator, dt, formulation, chunks)
    e, g = EMITTER.emitter(P), EMITTER.gravity(P)
    live = obs["id"] >= 0
    ids = obs["id"][live]
    k = np.rint((obs["t"][:, None] - obs["birth"])[live] / dt)
    x0, v0 = e.spawn_states(ids)
    xe, ve = em.discrete_path(integrator, x0, v0, g, dt, k, formulation)
    # the case's round-off part: n eps S over a life's steps plus the run's
    bound, _ = EMITTER.tolerance(P, "rk4", 4, dt)
    assert np.abs(obs["x"][live] - xe).max() <= bound
    assert np.abs(obs["v"][live] - ve).max() <= bound
    # same operations: the engines' births are birth_steps(...) * dt on the host
    assert np.array_equal(obs["birth"][live], em.birth_steps(e, dt, ids, formulation) * dt)
    assert settings["dtype"] == "float64" and settings["capacity"] == obs["id"].shape[1]
    if same_as:
        ref, _ = run(same_as, P, integrator, dt, formulation, chunks)
        for key in ("id", "birth", "emitted"):  # the same schedule, slot for slot
            # same operations: ids and counts are integers, births birth_steps * dt on either host
            assert np.array_equal(obs[key], ref[key], equal_nan=True), key
        # the same stepper arithmetic on the same numbers: equal to round-off
        assert np.abs(obs["x"] - ref["x"]).max() <= bound
        assert np.abs(obs["v"] - ref["v"]).max() <= bound
