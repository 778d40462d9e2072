"""taichi's gravity_pairs group against the in-house model: equal to round-off per stepper."""
import numpy as np
import pytest

from refsim_cases.gravity_pairs.kepler import CASE
from refsim.registry import get_engine
from refsim.scene import Particles, Scene
from refsim.scene.gravity_pairs import GravityPairs

pytest.importorskip("taichi")


@pytest.mark.parametrize("integrator", ["symplectic_euler", "velocity_verlet", "rk4"])
def test_taichi_equals_refsim_on_kepler(integrator):
    p = CASE.variant_params("e0.5")
    dt = CASE.dts(p)[1]
    steps = int(round(CASE.t_end(p) / dt))
    a = get_engine("taichi").build(CASE.scene(p), dt, integrator)
    b = get_engine("refsim").build(CASE.scene(p), dt, integrator)
    a.step(steps)
    b.step(steps)
    # same arithmetic up to the order of the pair sums: round-off, n eps S per step kept by
    # the orbit and amplified by the energy-period coupling (the case's own round-off bound)
    bound = CASE._roundoff(p, dt)[0]
    oa, ob = a.observe(), b.observe()
    assert np.max(np.abs(oa["x"] - ob["x"])) <= bound
    # exact zeros: a planar orbit, every z term is a product with an exact 0
    assert np.all(oa["x"][:, 2] == 0.0)
    assert a.settings()["dtype"] == "float64" and a.settings()["softening"] == 0.0


def test_softened_cluster_agrees_and_refuses_a_field():
    rng = np.random.default_rng(3)
    bodies = Particles(mass=rng.uniform(0.5, 1.5, 6), position=rng.normal(size=(6, 3)),
                       velocity=0.1 * rng.normal(size=(6, 3)))
    scene = Scene(parts=(bodies, GravityPairs(G=2.0, softening=0.3)))
    c = get_engine("taichi").build(scene, 0.01, "rk4")
    d = get_engine("refsim").build(scene, 0.01, "rk4")
    c.step(1)
    d.step(1)
    # one step: the two differ in the order of a 6-term pair sum (<= 6 eps |a| h^2 per
    # stage, negligible at h = 0.01) and in the rounding of the increments, eps |x| each of
    # the 4 stages' sums: 16 eps |x|, |x| <= 4 (standard normal positions)
    assert np.max(np.abs(c.observe()["x"] - d.observe()["x"])) <= 16 * np.finfo(float).eps * 4
    field = Scene(parts=(bodies, GravityPairs()), gravity=(0.0, 0.0, -1.0))
    assert "gravity" in get_engine("taichi").supports(field, "rk4")
