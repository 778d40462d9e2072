"""pybullet's pivoted rigid bodies (adapters/pybullet_engine/groups/pivots.py), what is
pybullet's own: a fixed-base multibody with one JOINT_SPHERICAL link, the settings it reports,
its initial observation and its refusal of unpivoted bodies. The checks every pivot engine
shares (the exact replica of the model's symplectic Euler step, the heavy top's order 1 against
DOP853, the compound pendulum's closed form; the group's claim, the integrator's name and order
in the settings, the observation contract) are in tests/conformance/test_conformance_pivots.py;
the scenes in tests/conformance/pivot_scenes.py.

pybullet is imported on purpose: CI must have every engine (fail, never skip).
"""
import numpy as np
import pybullet  # noqa: F401  (fail, never skip, without the engine)
from pivot_scenes import EPS, G, asymmetric, top

from refsim.registry import get_engine
from refsim.scene import RigidBodies, Scene
from refsim.scene.pivots import RigidPivots

ENGINE = get_engine("pybullet")
SE = "symplectic_euler"


def test_group_claims_pivoted_scenes_and_reports_settings():
    """What pybullet's settings add to the integrator's name and order (checked with the
    observation contract in tests/conformance/test_conformance_pivots.py), the joint motor
    switched off among them (docs/engine_notes.md#pybullet-joint-motors-act-as-friction); t = 0
    gives back the scene to round-off."""
    scene = asymmetric()
    assert ENGINE.group_for(scene).name == "pivots"
    sim = ENGINE.build(scene, 1e-3, SE)
    settings = sim.settings()
    assert settings["fixedTimeStep"] == 1e-3 and settings["gravity"] == [0.0, 0.0, -G]
    assert settings["linearDamping"] == settings["angularDamping"] == 0.0
    assert settings["jointDamping"] == 0.0 and settings["formulation"] == "multibody"
    for key in ("motor", "maxJointVelocity", "inertia", "joint", "orientation_update"):
        assert key in settings
    obs = sim.observe()
    r = scene.part(RigidBodies)
    for name, want in (("x", r.position), ("v", r.velocity), ("q", r.orientation),
                       ("w", r.angular_velocity)):
        np.testing.assert_allclose(obs[name], want, rtol=0, atol=10 * EPS * np.abs(want).max())


def test_unpivoted_bodies_are_refused():
    flat = top().part(RigidBodies)
    two = RigidBodies(mass=[1.0, 1.0], inertia=[flat.inertia[0]] * 2,
                      position=[flat.position[0], [5.0, 0.0, 0.0]],
                      orientation=[flat.orientation[0]] * 2)
    scene = Scene(parts=(two, top().part(RigidPivots)), gravity=(0.0, 0.0, -G))
    assert "must have a pivot" in ENGINE.supports(scene, SE)
