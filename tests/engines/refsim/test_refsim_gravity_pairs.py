"""The in-house gravity_pairs group: claims, supports, settings, observables, batch agreement."""
import numpy as np
import pytest

from refsim_cases.gravity_pairs.kepler import CASE
from refsim.registry import get_engine
from refsim.scene import Particles, Scene
from refsim.scene.gravity_pairs import GravityPairs


def scene(n=3, seed=0, **pairs):
    rng = np.random.default_rng(seed)
    bodies = Particles(mass=rng.uniform(0.5, 1.5, n), position=rng.normal(size=(n, 3)) * 2,
                       velocity=rng.normal(size=(n, 3)) * 0.1)
    return Scene(parts=(Particles.of(bodies), GravityPairs(**pairs)))


def test_group_claims_and_offers_its_steppers():
    engine = get_engine("refsim")
    sc = scene()
    assert engine.group_for(sc).name == "gravity_pairs"
    assert "velocity_verlet" in engine.offered_integrators(sc)
    assert engine.supports(sc, "rk4") is None
    assert "offers no integrator" in engine.supports(sc, "baraff_witkin")
    assert "dense" in engine.supports(scene(n=101), "implicit_euler")


def test_settings_name_softening_and_all_pairs():
    sim = get_engine("refsim").build(scene(softening=0.05), 0.01, "velocity_verlet")
    s = sim.settings()
    assert s["softening"] == 0.05 and s["G"] == 1.0 and "all pairs" in s["pairs"]
    assert s["integrator"]["symplectic"] is True


def test_observed_extras_are_the_models_invariants():
    sim = get_engine("refsim").build(CASE.scene(CASE.variant_params("e0.5")), 0.01, "rk4")
    sim.step(10)
    o = sim.observe()
    assert o["x"].shape == (2, 3) and o["runge_lenz"].shape == (3,)
    assert np.all(o["x"][:, 2] == 0.0)  # in its plane: every z term is a product with 0


def test_one_step_equals_hand_kick_drift():
    sc = scene(n=4, softening=0.1)
    sim = get_engine("refsim").build(sc, 0.05, "symplectic_euler")
    sim.step(1)
    from refsim.models.nbody_gravity import pair_accelerations
    p = sc.part(Particles)
    v1 = p.velocity + 0.05 * pair_accelerations(p.position, p.mass, 1.0, 0.1)
    # same operations: the stepper's v + h a and x + h v1, numpy ufuncs, the same kernel on x
    np.testing.assert_array_equal(sim.observe()["v"], v1)
    np.testing.assert_array_equal(sim.observe()["x"], p.position + 0.05 * v1)


@pytest.mark.parametrize("integrator", ["explicit_euler", "midpoint", "rk4", "implicit_euler"])
def test_momentum_conserved_to_roundoff(integrator):
    from refsim.models.nbody_gravity import pair_accelerations
    sc = scene(n=5, softening=0.2)
    sim = get_engine("refsim").build(sc, 0.01, integrator)
    p0 = sim.observe()["momentum"]
    sim.step(200)
    force = np.sum(sc.part(Particles).mass * np.linalg.norm(pair_accelerations(
        sc.part(Particles).position, sc.part(Particles).mass, 1.0, 0.2), axis=-1))
    # sum m a cancels up to n^2 eps sum m |a| per evaluation; dt times that per stage, 4
    # stages, 200 steps; times 2: the bodies (~2 m apart, 0.1 m/s) barely move in 2 s, so
    # sum m |a| stays within a factor 2 of its start
    bound = 200 * 4 * 25 * np.finfo(float).eps * 0.01 * force * 2
    assert np.linalg.norm(sim.observe()["momentum"] - p0) <= bound
