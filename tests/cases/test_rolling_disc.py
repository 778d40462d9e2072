"""The rolling disc's reference: the closed-form accelerations and their consistency."""
import numpy as np
import pytest

from refsim_cases.contact_rolling.rolling_disc import (
    CASE,
    accelerations,
    body_inertia,
    critical_friction,
    downslope,
    normal,
    rolls,
)
from refsim.scene import RigidBodies, Walls


def test_disc_and_hoop_accelerations():
    g_sin = 9.81 * np.sin(np.pi / 6)
    assert accelerations(CASE.variant_params("disc"))[0] == pytest.approx(2 / 3 * g_sin,
                                                                          rel=1e-15)
    assert accelerations(CASE.variant_params("hoop"))[0] == pytest.approx(0.5 * g_sin,
                                                                          rel=1e-15)


def test_slipping_accelerations_and_regime():
    p = CASE.variant_params("slipping")
    assert not rolls(p) and rolls(CASE.variant_params("disc"))
    a, alpha = accelerations(p)
    theta = p["incline"]
    assert a == pytest.approx(9.81 * (np.sin(theta) - 0.1 * np.cos(theta)), rel=1e-15)
    # I alpha = mu m g cos r
    inertia = body_inertia(p)[1, 1]
    assert inertia * alpha == pytest.approx(0.1 * p["mass"] * 9.81 * np.cos(theta) * p["radius"],
                                            rel=1e-14)


def test_regimes_meet_at_critical_friction():
    """At mu = mu_c the slipping formulas give the rolling ones (continuity: a = alpha r)."""
    p = CASE.variant_params("disc")
    mu_c = critical_friction(p)
    rolling = accelerations({**p, "friction": mu_c})
    slipping = accelerations({**p, "friction": mu_c * (1 - 1e-12)})
    assert slipping == pytest.approx(rolling, rel=1e-10)


def test_reference_conserves_energy_while_rolling():
    p = CASE.variant_params("hoop")
    t = np.linspace(0, 1, 11)
    ref = CASE.reference(p, t)
    x = p["radius"] * normal(p) + ref["s"][:, None] * downslope(p)
    v = (accelerations(p)[0] * t)[:, None] * downslope(p)
    w = np.zeros((11, 3))
    w[:, 1] = ref["spin"]
    obs = {"x": x[:, None], "v": v[:, None], "w": w[:, None],
           "q": np.tile([1.0, 0, 0, 0], (11, 1, 1))}  # spin about y: q unused for |w_body|
    energy = CASE.energy(p, obs)
    assert np.ptp(energy) <= 1e-13 * CASE.energy_scale(p)
    assert np.max(np.abs(ref["residual"])) <= 1e-15 * accelerations(p)[0]


def test_scene_touches_the_incline():
    p = CASE.variant_params("disc")
    scene = CASE.scene(p)
    walls = scene.part(Walls)
    gap = (scene.part(RigidBodies).position[0] - walls.point[0]) @ walls.normal[0]
    assert gap == pytest.approx(p["radius"], rel=1e-15)
    assert {"shapes", "contacts", "walls", "rigid"} <= scene.features()


def test_first_order_bound_is_the_split_error_times_the_stated_safety_factor():
    """Order < 2: SAFETY x a t h / 2 (+ round-off, no soft contact given); order >= 2: a
    constant acceleration is exact, round-off only, so a dt-independent error (MuJoCo's
    slipping rk4, 1.9e-5) exceeds it."""
    from refsim_cases.contact_rolling.rolling_disc import SAFETY
    for variant in CASE.variants:
        p = CASE.variant_params(variant)
        a = accelerations(p)[0]
        for dt in CASE.dts(p):
            split = 0.5 * a * p["duration"] * dt
            first = CASE.tolerance(p, "symplectic_euler", 1, dt)[0]
            assert SAFETY * split <= first < SAFETY * split * (1 + 1e-9)
            assert CASE.tolerance(p, "rk4", 4, dt)[0] < 1e-11
