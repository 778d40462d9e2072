"""MuJoCo's pivoted rigid bodies (adapters/mujoco_engine/groups/pivots.py), what is MuJoCo's own:
the options its settings report, the initial observation, the energy behaviour of its four
integrators and its refusals. The checks every pivot engine shares (the exact replica of the
symplectic Euler step, the heavy top's convergence at each integrator's nominal order against
DOP853, the compound pendulum's closed form, with MuJoCo's rk4 bound; the group's claim, each
integrator's name and order in the settings, the observation contract) are in
tests/conformance/test_conformance_pivots.py; the scenes in tests/conformance/pivot_scenes.py.

The heavy top: m = 1 kg, I0 = diag(0.2, 0.2, 0.05) kg m^2, pivot 0.5 m below the centre of mass
on the symmetry axis, tilted 0.3 rad, spinning 10 rad/s about its axis: it nutates and precesses.
mujoco is imported on purpose: CI must have every engine (fail, never skip).
"""
import mujoco  # noqa: F401  (fail, never skip, without the engine)
import numpy as np
import pytest
from pivot_scenes import EPS, G, asymmetric, pivoted, rot, run, top

from refsim.registry import get_engine
from refsim.scene import RigidBodies, Scene
from refsim.scene.pivots import RigidPivots

ENGINE = get_engine("mujoco")
NOMINAL_ORDER = {"symplectic_euler": 1, "rk4": 4, "implicit": 1, "implicitfast": 1}


def _energy(obs, scene):
    r = scene.part(RigidBodies)
    R, w, v = rot(obs["q"][0]), obs["w"][0], obs["v"][0]
    return 0.5 * r.mass[0] * v @ v + 0.5 * w @ (R @ r.inertia[0] @ R.T) @ w \
        - r.mass[0] * np.asarray(scene.gravity) @ obs["x"][0]


def test_settings_report_mujocos_options():
    """What MuJoCo's settings add to the integrator's name and order (checked with the claim in
    tests/conformance/test_conformance_pivots.py), for each of its four integrators."""
    scene = asymmetric()
    for integrator in NOMINAL_ORDER:
        settings = ENGINE.build(scene, 1e-3, integrator).settings()
        assert settings["timestep"] == 1e-3 and settings["gravity"] == [0.0, 0.0, -G]
        for key in ("formulation", "pivots", "inertia", "quaternion", "gyroscopic", "damping",
                    "velocity_limits", "autoreset", "version"):
            assert key in settings


def test_initial_observation_is_the_scene():
    """t = 0: x, v, q, w are the scene's to round-off (a rotation and back: ~10 eps of |value|)."""
    scene = asymmetric()
    obs = ENGINE.build(scene, 1e-3, "rk4").observe()
    r = scene.part(RigidBodies)
    for name, want in (("x", r.position), ("v", r.velocity), ("q", r.orientation),
                       ("w", r.angular_velocity)):
        np.testing.assert_allclose(obs[name], want, rtol=0, atol=10 * EPS * np.abs(want).max())
    assert abs(obs["engine_energy"] - _energy(obs, scene)) <= 10 * EPS * abs(_energy(obs, scene))


def test_energy_euler_gains_implicit_loses_rk4_keeps():
    """Heavy top, 2 s at h = 1e-3 (E0 = 7.19 J). The explicit gyroscopic kick of Euler and
    implicitfast (which here is the same step) gains energy, implicit's linearised backward
    Euler loses it (measured +0.49 J and -0.45 J); RK4 keeps it within 1e-8 J (its truncation
    ~ (h |w|)^4 E per unit time ~ 1e-7 E; measured 5e-10). Every step keeps the ball joint
    exact (pivot_gap round-off) and the quaternion normalised (defect ~ eps)."""
    scene = top()
    e0 = _energy(ENGINE.build(scene, 1e-3, "rk4").observe(), scene)
    drift = {}
    for integrator in NOMINAL_ORDER:
        obs = run(ENGINE, scene, 1e-3, integrator, 2.0)
        drift[integrator] = _energy(obs, scene) - e0
        assert obs["pivot_gap"][0] < 10 * EPS and abs(obs["orientation_defect"][0]) < 10 * EPS
    assert drift["symplectic_euler"] > 0.01 * e0 and drift["implicitfast"] > 0.01 * e0
    assert drift["implicit"] < -0.01 * e0
    assert abs(drift["rk4"]) < 1e-8


def test_refusals_name_the_reason():
    scene = top()
    flat = scene.part(RigidBodies)
    two = RigidBodies(mass=[1.0, 1.0], inertia=[flat.inertia[0]] * 2,
                      position=[flat.position[0], [5.0, 0.0, 0.0]],
                      orientation=[flat.orientation[0]] * 2)
    unpivoted = Scene(parts=(two, scene.part(RigidPivots)), gravity=scene.gravity)
    assert "must have a pivot" in ENGINE.supports(unpivoted, "rk4")
    bad = pivoted(1.0, np.diag([0.1, 0.1, 0.5]), np.array([0.0, 0.0, -0.5]),
                  np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3))
    assert "A + B < C" in ENGINE.supports(bad, "rk4")
    off = Scene(parts=(flat, RigidPivots(body=[0], body_point=[[0.0, 0.0, -0.4]],
                                         anchor=[[0, 0, 0]])), gravity=scene.gravity)
    assert "start on its anchor" in ENGINE.supports(off, "rk4")
    with pytest.raises(ValueError, match="integrator"):
        ENGINE.build(scene, 1e-3, "discrete")
