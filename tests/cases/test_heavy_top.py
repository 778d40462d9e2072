"""The heavy top: its DOP853 reference's invariants, the linearised sleeping top, refsim's
convergence orders, its energy drift under symplectic Euler, and the sleeping threshold found
by bisection on refsim against I3^2 w3^2 = 4 I1' M g l."""
import numpy as np
import pytest

from refsim_adapters.planted_defects.checks import defect_uncaught
from refsim_cases.rigid.heavy_top import (
    CASE,
    find_threshold,
    linear_tilt_ratio,
    pivot_moments,
    reference_state,
    sleeping_threshold,
    spin,
    threshold_rate,
)
from refsim.registry import get_engine

ENGINE = get_engine("refsim")


def _run(variant, integrator, dt, formulation="quat_exp", overrides=None):
    p = CASE.variant_params(variant, overrides)
    sim = ENGINE.build(CASE.scene(p), dt, integrator, formulation)
    n = round(p["duration"] / dt)
    every = max(1, n // 100)
    frames = [sim.observe()]
    while sim.steps < n:
        sim.step(min(every, n - sim.steps))
        frames.append(sim.observe())
    obs = {k: np.array([f[k] for f in frames]) for k in frames[0]}
    return p, obs


def _error(variant, integrator, dt):
    p, obs = _run(variant, integrator, dt)
    return np.max(CASE.error(p, CASE.observables(p, obs), CASE.reference(p, obs["t"])))


@pytest.mark.parametrize("variant", list(CASE.variants))
def test_reference_conserves_energy_and_both_momenta(variant):
    p = CASE.variant_params(variant)
    t = np.linspace(0.0, p["duration"], 501)
    w_body, q = reference_state(p, t)
    obs = {"q": q[:, None], "w": np.einsum("tij,tj->ti", _matrices(q), w_body)[:, None]}
    energy = CASE.energy(p, obs)
    out = CASE.observables(p, obs)
    l3 = p["I3"] * spin(p)
    # DOP853 at rtol 1e-12: the local error per step is below 1e-12 of the state, and over
    # the few thousand steps of the run the invariants drift by at most ~1e-9 of their scale
    assert np.max(np.abs(energy - energy[0])) < 1e-9 * CASE.energy_scale(p)
    assert np.max(np.abs(out["L_z"] - l3 * np.cos(p["tilt"]))) < 1e-9 * l3
    assert np.max(np.abs(out["L_3"] - l3)) < 1e-9 * l3


def _matrices(q):
    from refsim_cases.rigid import quat_to_matrix
    return quat_to_matrix(q)


def test_stable_sleeping_top_reaches_the_linear_maximum_tilt():
    p = CASE.variant_params("sleeping_stable", {"duration": 8.0})
    r = p["spin_ratio"]
    t = np.linspace(0.0, p["duration"], 4001)
    tilt = CASE.reference(p, t)["tilt"]
    linear = p["tilt"] * linear_tilt_ratio(r, threshold_rate(p) * t)
    # nonlinear terms are O(theta^2) = 1e-6 relative at theta <= 1.4e-3 rad; 1e-4 covers them
    np.testing.assert_allclose(tilt, linear, rtol=1e-4, atol=0)
    # the modes beat within 8 s: the maximum theta0 r / sqrt(r^2 - 1) is reached (to 1e-3)
    assert tilt.max() == pytest.approx(p["tilt"] * r / np.sqrt(r * r - 1), rel=1e-3)


def test_sleeping_variants_stay_up_or_fall_on_refsim():
    _, stable = _run("sleeping_stable", "rk4", 4e-3)
    _, unstable = _run("sleeping_unstable", "rk4", 4e-3)
    tilt_up = CASE.observables(CASE.variant_params("sleeping_stable"), stable)["tilt"]
    tilt_down = CASE.observables(CASE.variant_params("sleeping_unstable"), unstable)["tilt"]
    assert tilt_up.max() < 2e-3 and tilt_down.max() > 0.5


@pytest.mark.parametrize("integrator,order", [("symplectic_euler", 1), ("rk4", 4),
                                              ("implicit_midpoint", 2)])
def test_refsim_order_on_the_nutating_top(integrator, order):
    coarse, fine = (_error("nutation", integrator, dt) for dt in CASE.order_dts(
        CASE.variant_params("nutation")))
    # the next term of the error expansion is O(W dt) = 0.25 of the leading one at most at
    # dt = 1.6e-2 (W = 15.3 rad/s): log2 of the ratio within 0.4 of p
    assert np.log2(coarse / fine) == pytest.approx(order, abs=0.4)


def test_symplectic_euler_energy_grows_on_the_top():
    """Declared not symplectic: the energy error grows with t (no bounded oscillation)."""
    p, obs = _run("nutation", "symplectic_euler", 8e-3, overrides={"duration": 6.0})
    energy = CASE.energy(p, obs)
    half = len(energy) // 2
    early = np.max(np.abs(energy[:half] - energy[0]))
    late = np.max(np.abs(energy[half:] - energy[0]))
    assert late > 1.5 * early  # secular: twice the time, about twice the drift
    sim = ENGINE.build(CASE.scene(p), 8e-3, "symplectic_euler", "quat_exp")
    assert sim.settings()["integrator"]["symplectic"] is False


def test_refsim_meets_the_case_tolerance_on_every_default_variant():
    for variant in CASE.default_variants:
        p = CASE.variant_params(variant)
        for integrator, order in (("symplectic_euler", 1), ("rk4", 4)):
            dt = CASE.dts(p)[0]
            tol, reason = CASE.tolerance(p, integrator, order, dt)
            assert _error(variant, integrator, dt) < tol, reason


def test_sleeping_threshold_formula_and_bisection_on_refsim():
    p = CASE.variant_params("sleeping_stable")
    i1p = p["I1"] + p["mass"] * p["length"] ** 2
    # same operations: pivot_moments computes I1 + M l^2 in this order
    assert pivot_moments(p)[0] == i1p
    assert (p["I3"] * sleeping_threshold(p)) ** 2 == pytest.approx(
        4 * i1p * p["mass"] * p["g"] * p["length"], rel=1e-14)
    periods, factor, resolution = 2.0, 10.0, 2e-3
    found = find_threshold(ENGINE, "rk4", 1e-2, "quat_exp", low=0.9, high=1.1,
                           resolution=resolution, periods=periods, factor=factor)
    # the criterion itself, on the linearised top: bisect the closed form the same way
    tau = np.linspace(0.0, 2 * np.pi * periods, 20001)
    low, high = 0.9, 1.1
    while high - low > 1e-6:
        mid = 0.5 * (low + high)
        low, high = (low, mid) if linear_tilt_ratio(mid, tau).max() < factor else (mid, high)
    linear = 0.5 * (low + high)
    # the criterion's own offset from r = 1 (finite time, finite factor) is below the factor's
    # r / sqrt(r^2 - 1) = 10 bound, r = 1.005
    assert 1.0 <= linear < factor / np.sqrt(factor ** 2 - 1) + 1e-6
    # refsim's bisection: the resolution, the chunked check (a quarter radian of Omega_c
    # between looks: the tilt ratio changes by < 3 % between looks near r = 1, a shift of
    # r by < 1e-3), nonlinear terms O(theta^2) = 1e-4 and RK4's error at W dt = 0.08
    # (relative frequency error ~ (W dt)^4 = 4e-5): 2e-3 + 1e-3 + 1e-4 + 4e-5 < 4e-3
    assert abs(found - linear) < 4e-3


def test_bad_input():
    with pytest.raises(ValueError, match="I3 must differ"):
        CASE.scene(CASE.validate({"I1": 1.0, "I3": 1.0}))
    with pytest.raises(ValueError, match="spin_ratio"):
        CASE.validate({"spin_ratio": -1.0})
    with pytest.raises(ValueError, match="low < high"):
        find_threshold(ENGINE, "rk4", 1e-2, low=1.2, high=1.0)


@pytest.mark.parametrize("defect", ["heun_as_rk4", "rk3_as_rk4"])
def test_an_rk4_that_is_heun_or_kutta_rk3_exceeds_the_rk4_bound_at_every_dt(defect):
    p = CASE.variant_params('nutation')
    assert not defect_uncaught(CASE, p, defect, "rk4", 4, CASE.dts(p)), defect


@pytest.mark.parametrize("defect", ["gravity_plus_0.1pct", "rest_length_plus_0.5pct",
                                    "velocity_damping"])
def test_a_wrong_parameter_exceeds_the_rk4_bound_at_the_finest_dt(defect):
    p = CASE.variant_params('nutation')
    assert not defect_uncaught(CASE, p, defect, "rk4", 4, [min(CASE.dts(p))]), defect


def test_a_velocity_verlet_that_is_explicit_euler_exceeds_the_verlet_bound_at_every_dt():
    """refsim's rigid group offers no velocity Verlet; its explicit Euler rows stand for an
    engine whose "velocity_verlet" is explicit Euler: every one errs above Verlet's bound."""
    p = CASE.variant_params('nutation')
    assert not defect_uncaught(CASE, p, "control", "explicit_euler", 2, CASE.dts(p),
                               named="velocity_verlet")
