"""taichi's emitter kernels: every particle on the exact discrete parabola of its stepper (to
round-off), and the same ids, births, counts and states as refsim's group, per stepper and
formulation, with births falling inside and between launches of any length."""
import numpy as np
import pytest

pytest.importorskip("taichi")

from refsim_cases.particle_fields.sprinkler import CASE as EMITTER
from refsim.models import emitter as em
from refsim.registry import get_engine

STEPPERS = ("symplectic_euler", "velocity_verlet", "rk4", "explicit_euler", "midpoint")
CHUNKS = (1, 2, 3, 7, 10, 13, 1, 40)  # Sim.step(n) lengths: births mid-launch and at its end


def _run(engine, p, integrator, dt, formulation, chunks=CHUNKS):
    sim = get_engine(engine).build(EMITTER.scene(p), dt, integrator, formulation)
    out = [sim.observe()]
    for n in chunks:
        sim.step(n)
        out.append(sim.observe())
    settings = sim.settings()
    sim.close()
    return {k: np.array([o[k] for o in out]) for k in out[0]}, settings


@pytest.mark.parametrize("integrator", STEPPERS)
@pytest.mark.parametrize("formulation", ["corrected", "as_printed"])
@pytest.mark.parametrize("dt", EMITTER.dts(EMITTER.variant_params("default")))
def test_every_particle_on_its_exact_discrete_path_as_refsim(integrator, formulation, dt):
    p = EMITTER.variant_params("default")
    obs, settings = _run("taichi", p, integrator, dt, formulation)
    ref, _ = _run("refsim", p, integrator, dt, formulation)
    e, g = EMITTER.emitter(p), EMITTER.gravity(p)
    live = obs["id"] >= 0
    ids = obs["id"][live]
    k = np.rint((obs["t"][:, None] - obs["birth"])[live] / dt)
    x0, v0 = e.spawn_states(ids)
    xe, ve = em.discrete_path(integrator, x0, v0, g, dt, k, formulation)
    # the case's round-off part: n eps S over a life's steps plus the run's
    bound, _ = EMITTER.tolerance(p, "rk4", 4, dt)
    assert np.abs(obs["x"][live] - xe).max() <= bound
    assert np.abs(obs["v"][live] - ve).max() <= bound
    for key in ("id", "birth", "emitted"):  # the same schedule, slot for slot
        assert np.array_equal(obs[key], ref[key], equal_nan=True), key
    # the same stepper arithmetic on the same numbers: equal to round-off (measured: bit
    # for bit; both run refsim's tableau in the same order)
    assert np.abs(obs["x"] - ref["x"]).max() <= bound
    assert np.abs(obs["v"] - ref["v"]).max() <= bound
    assert settings["dtype"] == "float64" and settings["capacity"] == obs["id"].shape[1]


def test_counts_match_rate_times_time_and_refsim():
    p = EMITTER.variant_params("default")
    dt = EMITTER.dts(p)[-1]
    chunks = (1,) * 20 + (30, 150)  # the whole run, 1 s
    obs, _ = _run("taichi", p, "rk4", dt, "corrected", chunks)
    ref, _ = _run("refsim", p, "rk4", dt, "corrected", chunks)
    e = EMITTER.emitter(p)
    alive = (obs["id"] >= 0).sum(axis=1)
    assert np.array_equal(alive, (ref["id"] >= 0).sum(axis=1))
    assert np.abs(alive - em.continuum_alive(e, obs["t"])).max() <= em.count_bound(e, dt)
    assert np.array_equal(obs["emitted"], em.emitted_count(e, dt, np.rint(obs["t"] / dt)))


def test_dense_emitter_many_births_per_slot_in_one_launch():
    """rate 2000/s: several births a step and, over one launch of 300 steps, up to two per
    slot (lifetime 1 s = 200 steps): the kernel's event lists in boundary order."""
    p = EMITTER.variant_params("dense")
    dt = 5e-3
    obs, _ = _run("taichi", p, "velocity_verlet", dt, "corrected", (300, 1))
    ref, _ = _run("refsim", p, "velocity_verlet", dt, "corrected", (300, 1))
    for key in ("id", "birth", "emitted"):
        assert np.array_equal(obs[key], ref[key], equal_nan=True), key
    bound, _ = EMITTER.tolerance(p, "rk4", 4, dt)
    assert np.abs(obs["x"] - ref["x"]).max() <= bound


def test_emitter_settings_and_refusal():
    p = EMITTER.variant_params("default")
    engine = get_engine("taichi")
    scene = EMITTER.scene(p)
    assert engine.formulations(scene) == ("corrected", "as_printed")
    assert engine.offered_integrators(scene) == STEPPERS
    sim = engine.build(scene, 0.01, "rk4", "as_printed")
    s = sim.settings()
    assert s["capacity"] == 50 and "velocity == g*dt" in s["formulation"]
    assert "host" in s["births_removals"] and s["default_fp"].endswith("f64")
    reason = engine.supports(scene, "leapfrog")
    assert reason is not None and "leapfrog" in reason
