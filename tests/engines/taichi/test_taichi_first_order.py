"""taichi's first-order group: the same exact discrete solutions as refsim, to round-off."""
import numpy as np
import pytest

from refsim_cases.first_order_fields.advection_vortex import CASE as VORTEX
from refsim_cases.first_order_fields.gradient_descent import CASE as DESCENT
from refsim_cases.first_order_fields.sphere_sampling import CASE as SAMPLING
from refsim import registry
from refsim.integrators.first_order import get_first_order
from refsim.models.advection import discrete_positions
from refsim.scene.velocity_field import VelocityField

pytest.importorskip("taichi")
FIELD_STEPPERS = ("explicit_euler", "midpoint", "heun", "rk4", "implicit_euler")
EPS = np.finfo(float).eps


@pytest.mark.parametrize("case", [VORTEX, DESCENT], ids=["vortex", "descent"])
@pytest.mark.parametrize("integrator", FIELD_STEPPERS)
def test_taichi_matches_the_exact_discrete_solution_and_refsim(case, integrator):
    """After k steps: |taichi - (c + R(hM)^k (p0 - c))| and |taichi - refsim| within the
    round-off 2 k eps G S of the case's tolerance (G the largest growth, S the largest |p|)."""
    p = case.variant_params("default", {"particles": 20})
    scene, dt, k = case.scene(p), case.dts(p)[0], 40
    field = scene.part(VelocityField)
    runs = {}
    for name in ("taichi", "refsim"):
        sim = registry.get_engine(name).build(scene, dt, integrator)
        sim.step(k)
        runs[name] = sim.observe()["x"]
    oracle = discrete_positions(get_first_order(integrator), field.matrix(),
                                np.array(field.centre), case.start(p), dt, [k])[0]
    growth = max(1.0, float(np.max(np.abs(get_first_order(integrator).stability(
        dt * np.linalg.eigvals(field.matrix()))))) ** k)
    scale = np.max(np.abs(case.start(p))) + growth * case.motion_scale(p)
    bound = 2 * k * EPS * growth * scale
    assert np.max(np.abs(runs["taichi"] - oracle)) <= bound
    assert np.max(np.abs(runs["taichi"] - runs["refsim"])) <= bound


def test_taichi_refusals_and_settings():
    engine = registry.get_engine("taichi")
    sampling = SAMPLING.scene(SAMPLING.variant_params("tetrahedron"))
    assert engine.supports(sampling, "explicit_euler") is None
    assert "not affine" in engine.supports(sampling, "implicit_euler")
    scene = VORTEX.scene(VORTEX.variant_params("default", {"particles": 3}))
    assert "needs x'' = a" in engine.supports(scene, "symplectic_euler")
    sim = engine.build(scene, 0.1, "rk4")
    settings = sim.settings()
    assert settings["dtype"] == "float64" and settings["integrator"]["order"] == 4
