"""pybullet's n-body gravity (adapters/pybullet_engine/groups/gravity_pairs.py), what is
pybullet's own: free multibody bases pushed by applyExternalForce each step, and its settings.
The checks shared with MuJoCo and pymunk (the group's claim and cost, each step against
refsim's symplectic_euler to the rounding of one update (bit for bit on x86-64), order 1 on the
Kepler orbit, energy and angular momentum, the figure-eight) are in
tests/conformance/test_conformance_gravity_pairs.py; the scenes in
tests/conformance/gravity_scenes.py.
pybullet is imported on purpose: CI must have every engine (fail, never skip).
"""
from gravity_scenes import kepler

from refsim_adapters.pybullet_engine.runtime import import_pybullet
from refsim.registry import get_engine

import_pybullet()  # fail, never skip, without the engine
ENGINE = get_engine("pybullet")
INTEGRATOR = "symplectic_euler"


def test_settings_count_the_python_calls_and_switch_off_bullets_gravity_and_damping():
    """The claim, the cost per step and the order: tests/conformance/
    test_conformance_gravity_pairs.py."""
    sim = ENGINE.build(kepler(0.5), 0.01, INTEGRATOR, "")
    s = sim.settings()
    sim.close()
    assert s["python_calls_per_step"] == 5 and s["numSubSteps"] == 0
    assert s["fixedTimeStep"] == 0.01 and s["gravity"] == [0.0, 0.0, 0.0]
    assert s["linearDamping"] == 0.0
