"""pymunk's pivoted rigid bodies (adapters/pymunk_engine/groups/pivots.py), what is pymunk's own:
the options its settings report, the pivot's drift (a constraint, not a generalized coordinate), the
energy of its drift-kick step and the "pymunk is 2D" refusals. The compound pendulum's
convergence to its closed form (w0^2 = 3 g / (2 L)) and the group's claim with the integrator's
name and order and the observation contract, shared with the other pivot engines, are in
tests/conformance/test_conformance_pivots.py; the rod (length L pivoted at one end, I = m L^2 /
12 about its centre, swinging in the x-z plane) in tests/conformance/pivot_scenes.py.
pymunk is imported on purpose: CI must have every engine (fail, never skip).
"""
import numpy as np
import pymunk  # noqa: F401  (fail, never skip, without the engine)
import pytest
from pivot_scenes import EPS, G, L, M, pivoted, rod, run, top
from scipy.spatial.transform import Rotation

from refsim.registry import get_engine
from refsim.scene import RigidBodies

ENGINE = get_engine("pymunk")
DK = "symplectic_euler_dk"


def _rod():
    return rod(planar=True)  # pymunk is 2D: planar scenes only


def _energy(obs):
    v, w, x = obs["v"][0], obs["w"][0], obs["x"][0]
    return 0.5 * M * v @ v + 0.5 * (M * L * L / 12) * w @ w + M * G * x[2]


def test_settings_report_the_space_and_the_rod_is_observed_at_start():
    """What pymunk's settings add to the integrator's name and order (checked with the claim in
    tests/conformance/test_conformance_pivots.py); t = 0 gives back the scene to round-off."""
    scene = _rod()
    sim = ENGINE.build(scene, 1e-3, DK)
    settings = sim.settings()
    assert settings["joints"]["error_bias"] == [0.0]
    assert settings["space"]["damping"] == 1.0 and settings["space"]["gravity"] == [0.0, -G]
    assert settings["bodies"]["moment"] == [pytest.approx(M * L * L / 12, rel=4 * EPS)]
    obs = sim.observe()
    r = scene.part(RigidBodies)
    for name, want in (("x", r.position), ("v", r.velocity), ("q", r.orientation),
                       ("w", r.angular_velocity)):
        np.testing.assert_allclose(obs[name], want, rtol=0, atol=4 * EPS)
    assert obs["orientation_defect"][0] == 0.0 and obs["pivot_gap"][0] < 4 * EPS


def test_pivot_gap_is_second_order():
    """error_bias = 0: each step's bias velocity removes the whole gap, so what remains is the
    one-step drift of the curved path, O(h^2): a halving divides it by 4 (order 2 within 0.15,
    measured 1.99 and 2.00)."""
    gaps = [run(ENGINE, _rod(), h, DK, 2.0)["pivot_gap"][0] for h in (2e-3, 1e-3, 5e-4)]
    orders = np.log2(np.array(gaps[:-1]) / gaps[1:])
    assert np.all(np.abs(orders - 2.0) < 0.15), (gaps, orders)


def test_energy_error_is_bounded_not_secular():
    """20 s (9 periods) at h = 1 ms: the largest relative energy error of the second 10 s is
    that of the first within 5 % (a secular drift would double it; measured 0.07 %), and it
    is first order: halving h halves it (order 1 within 0.15, measured 1.005)."""
    worst = []
    for h in (2e-3, 1e-3):
        sim = ENGINE.build(_rod(), h, DK)
        e0, errors = _energy(sim.observe()), []
        for _ in range(200):
            sim.step(round(0.1 / h))
            errors.append(abs(_energy(sim.observe()) - e0) / abs(e0))
        first, second = max(errors[:100]), max(errors[100:])
        assert second <= 1.05 * first, (first, second)
        worst.append(second)
    assert abs(np.log2(worst[0] / worst[1]) - 1.0) < 0.15, worst


def test_refusals_say_pymunk_is_2d():
    top_out_of_plane = top(planar=True)  # tilted 0.3 rad about x: out of plane
    assert ENGINE.supports(top_out_of_plane, DK).startswith("pymunk is 2D")
    skew = Rotation.from_rotvec([0.2, 0.0, 0.3]).as_matrix()  # principal axes off y
    inertia = skew @ np.diag([0.1, 0.2, 0.3]) @ skew.T
    tilted = pivoted(M, inertia, np.array([0.0, 0.0, L / 2]),
                     np.array([np.cos(0.5), 0.0, np.sin(0.5), 0.0]), planar=True)
    reason = ENGINE.supports(tilted, DK)
    assert reason.startswith("pymunk is 2D") and "principal axis" in reason
    assert ENGINE.supports(_rod(), DK) is None
