"""MuJoCo's n-body gravity (adapters/mujoco_engine/groups/gravity_pairs.py), what is MuJoCo's
own: its two formulations (xfrc_per_step, passive_callback) and their settings, the
process-global callback, RK4 through the callback against refsim's rk4, and the xfrc pitfall in
the conservation laws. The checks shared with pybullet and pymunk (the group's claim with the
default formulation's cost and order, each step against refsim's kick-drift to the rounding
of one update (bit for bit on x86-64), the return
error's order on the Kepler orbit, energy and angular momentum under symplectic Euler, the
figure-eight) are in tests/conformance/test_conformance_gravity_pairs.py;
the scenes (Kepler from true anomaly pi/2, the figure-eight) in
tests/conformance/gravity_scenes.py.
mujoco is imported on purpose: CI must have every engine (fail, never skip).
"""
import mujoco  # fail, never skip, without the engine
import numpy as np
from gravity_scenes import EPS, TWO_PI, energy_and_l, in_house, kepler

import gravity_scenes
from refsim.engine import IntegratorInfo
from refsim.registry import get_engine

ENGINE = get_engine("mujoco")


def test_group_names_its_formulations():
    """The claim and the default formulation's cost and order: tests/conformance/
    test_conformance_gravity_pairs.py."""
    scene = kepler(0.5)
    assert ENGINE.formulations(scene) == ("", "passive_callback")
    assert ENGINE.supports(scene, "discrete") is not None
    s = ENGINE.build(scene, 0.01, "rk4", "").settings()
    assert s["integrator"]["nominal_order"] == 4
    s = ENGINE.build(scene, 0.01, "rk4", "passive_callback").settings()
    assert IntegratorInfo.of(s).order == 4 and "process-global" in s["callback_scope"]


def test_callback_is_removed_after_stepping():
    """mjcb_passive is a process-global C pointer: nothing of ours may stay installed."""
    sim = ENGINE.build(kepler(0.5), 0.01, "rk4", "passive_callback")
    sim.step(3)
    assert mujoco.get_mjcb_passive() is None


def test_rk4_callback_is_refsim_rk4_to_round_off():
    """Same method, different stage arithmetic: round-off of steps x eps x scale (|x| ~ 1),
    amplified by Kepler's shear (a relative energy error dE shifts the phase by 3/2 dE w t):
    bound steps eps (1 + 3/2 w T) = 1000 x 2.2e-16 x 10.4 = 2.3e-12 (measured 3e-14)."""
    scene, steps = kepler(0.5), 1000
    obs = gravity_scenes.run(ENGINE, scene, "rk4", "passive_callback", TWO_PI, steps)
    x, _ = in_house(scene, "rk4", TWO_PI / steps, steps)
    assert np.abs(obs["x"] - x).max() <= steps * EPS * (1.0 + 1.5 * TWO_PI)


def test_frozen_rk4_drifts_where_the_callback_does_not():
    """The xfrc pitfall seen in the conservation laws: frozen-force RK4 gains |dE| per period
    (first period 0.017, fifth 0.041 at T/400) and loses L (h^2/2 sum m v x a per step), the
    callback form keeps E to 1.4e-8 over 5 periods (RK4's h^4 T error: 1e-8 at T/400)."""
    frozen, dl_frozen = energy_and_l(ENGINE, kepler(0.5), "rk4", "", 400)
    staged, dl_staged = energy_and_l(ENGINE, kepler(0.5), "rk4", "passive_callback", 400)
    assert frozen[-1] > 1.5 * frozen[0] and dl_frozen > 1e-3
    assert staged.max() < 1e-3 * frozen[0] and dl_staged < 1e-3 * dl_frozen
