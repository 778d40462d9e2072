"""The refsim engine's first-order group: claims, offered steppers, observation, settings."""
import json

import numpy as np

from refsim_cases.first_order_fields.advection_vortex import CASE as VORTEX
from refsim_cases.first_order_fields.sphere_sampling import CASE as SAMPLING
from refsim import registry
from refsim.observation import check_observation
from refsim.scene import Particles, Scene
from refsim.scene.velocity_field import VelocityField
from ulp import assert_ulp


def test_group_claims_and_offers_first_order_only():
    engine = registry.get_engine("refsim")
    scene = VORTEX.scene(VORTEX.variant_params("default", {"particles": 5}))
    assert engine.group_for(scene).name == "first_order_fields"
    runnable = [i for i in engine.offered_integrators(scene) if engine.supports(scene, i) is None]
    assert runnable == ["explicit_euler", "midpoint", "heun", "rk4", "implicit_euler"]
    sampling = SAMPLING.scene(SAMPLING.variant_params("tetrahedron"))
    assert "implicit_euler" not in [i for i in engine.offered_integrators(sampling)
                                    if engine.supports(sampling, i) is None]
    assert "needs x'' = a" in engine.supports(sampling, "velocity_verlet")


def test_gravity_refused():
    scene = Scene(parts=(Particles(mass=[1.0], position=[[0.0, 0.0, 1.0]]), VelocityField()), gravity=(0.0, 0.0, -9.81))
    assert "gravity" in registry.get_engine("refsim").supports(scene, "rk4")


def test_observation_contract_and_settings():
    engine = registry.get_engine("refsim")
    scene = VORTEX.scene(VORTEX.variant_params("default", {"particles": 5}))
    sim = engine.build(scene, 0.1, "rk4")
    sim.step(3)
    obs = sim.observe()
    assert check_observation(obs, scene) == []
    field = VelocityField("rigid_vortex", centre=scene.part(VelocityField).centre,
                          omega=scene.part(VelocityField).omega)
    d, m = obs["x"] - np.array(field.centre), field.matrix()
    # each v_j = sum_k d_k M_jk by matmul, here on M.T (a view) and in the engine on a copy
    # of it: BLAS may take another kernel (and fused multiply-adds) per layout. Each side is
    # within 1.5 eps of sum_k |d_k M_jk| (three terms), so 3 ulps of that apart at most.
    assert_ulp(obs["v"], d @ m.T, 3, "another matmul layout", scale=np.abs(d) @ np.abs(m).T)
    settings = json.loads(json.dumps(sim.settings()))
    assert settings["integrator"]["order"] == 4 and settings["dtype"] == "float64"
    assert "first order" in settings["system"]
