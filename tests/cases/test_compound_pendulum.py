"""The compound pendulum: its elliptic reference against DOP853, the two inertias (rod against
point mass), and refsim's orders and tolerance."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from refsim_adapters.planted_defects.checks import defect_uncaught
from refsim_cases.pivots.compound_pendulum import CASE, rod_rate, small_swing_periods
from refsim.registry import get_engine

ENGINE = get_engine("refsim")


def _run(variant, integrator, dt, formulation="quat_exp"):
    p = CASE.variant_params(variant)
    sim = ENGINE.build(CASE.scene(p), dt, integrator, formulation)
    n = round(p["duration"] / dt)
    frames = [sim.observe()]
    while sim.steps < n:
        sim.step(min(max(1, n // 200), n - sim.steps))
        frames.append(sim.observe())
    return p, {k: np.array([f[k] for f in frames]) for k in frames[0]}


def _error(variant, integrator, dt, formulation="quat_exp"):
    p, obs = _run(variant, integrator, dt, formulation)
    return np.max(CASE.error(p, CASE.observables(p, obs), CASE.reference(p, obs["t"])))


@pytest.mark.parametrize("variant", list(CASE.variants))
def test_reference_matches_dop853_of_the_rod_equation(variant):
    p = CASE.variant_params(variant)
    w0 = rod_rate(p)
    t = np.linspace(0.0, p["duration"], 401)
    sol = solve_ivp(lambda _, y: [y[1], -w0 ** 2 * np.sin(y[0])], (0.0, t[-1]),
                    [p["theta0"], 0.0], method="DOP853", rtol=1e-12, atol=1e-14, t_eval=t)
    # both converged: DOP853's global error ~ 10 rtol theta0 w0 t = 1.5e-10 theta0
    np.testing.assert_allclose(CASE.reference(p, t)["theta"], sol.y[0], rtol=0,
                               atol=1e-9 * p["theta0"])


def test_rod_and_point_mass_periods_differ_by_sqrt_two_thirds():
    p = CASE.variant_params("small")
    rod, point = small_swing_periods(p)
    assert rod == pytest.approx(2 * np.pi * np.sqrt(2 * p["length"] / (3 * p["g"])), rel=1e-15)
    assert rod / point == pytest.approx(np.sqrt(2 / 3), rel=1e-15)
    # measured on refsim: the first downward zero crossing of theta is a quarter period
    # (the elliptic correction at theta0 = 0.05 is theta0^2 / 16 = 1.6e-4 of it)
    p, obs = _run("small", "rk4", 2e-3)
    theta = CASE.observables(p, obs)["theta"]
    k = np.argmax(theta < 0)
    t0, t1 = obs["t"][k - 1], obs["t"][k]
    crossing = t0 + (t1 - t0) * theta[k - 1] / (theta[k - 1] - theta[k])
    # linear interpolation between samples 20 ms apart errs by w0^2 dt_s^2 / 8 of a radian
    # of phase at most near the zero: < 1e-3 of the quarter period
    assert 4 * crossing == pytest.approx(rod, rel=2e-3)
    assert abs(4 * crossing - point) > 0.1 * point


def test_pivot_holds_the_rod_end_at_the_origin():
    p, obs = _run("default", "symplectic_euler", 8e-3)
    from refsim_cases.rigid import quat_to_matrix
    top = obs["x"][:, 0] + np.einsum("tij,j->ti", quat_to_matrix(obs["q"][:, 0]),
                                     [0.0, 0.0, 0.5 * p["length"]])
    # x = anchor + R c in generalized coordinates: round-off only (a few eps of L)
    assert np.max(np.abs(top)) < 1e-14 * p["length"]
    # exact zeros: hinge about y, every x, z term of w is a product with an exact 0
    assert np.max(np.abs(obs["w"][:, 0, [0, 2]])) == 0.0  # w stays along world y


@pytest.mark.parametrize("integrator,order", [("symplectic_euler", 1), ("rk4", 4),
                                              ("implicit_midpoint", 2)])
def test_refsim_order_on_the_rod(integrator, order):
    p = CASE.variant_params("default")
    coarse, fine = (_error("default", integrator, dt) for dt in CASE.order_dts(p))
    # next error term O(w0 dt) = 0.12 of the leading one at dt = 3.2e-2: log2 within 0.2
    assert np.log2(coarse / fine) == pytest.approx(order, abs=0.2)


@pytest.mark.parametrize("formulation", ["quat_exp", "quat_normalised", "matrix_polar",
                                         "matrix_printed"])
def test_refsim_meets_the_case_tolerance(formulation):
    p = CASE.variant_params("default")
    dt = CASE.dts(p)[0]
    for integrator, order in (("symplectic_euler", 1), ("rk4", 4)):
        settings = ENGINE.build(CASE.scene(p), dt, integrator, formulation).settings()
        tol, reason = CASE.tolerance(p, integrator, order, dt, formulation, settings)
        assert _error("default", integrator, dt, formulation) < tol, reason


def test_bad_input():
    with pytest.raises(ValueError, match="theta0"):
        CASE.validate({"theta0": 4.0})
    with pytest.raises(ValueError, match="length"):
        CASE.validate({"length": 0.0})


@pytest.mark.parametrize("defect", ["heun_as_rk4", "rk3_as_rk4"])
def test_an_rk4_that_is_heun_or_kutta_rk3_exceeds_the_rk4_bound_at_every_dt(defect):
    p = CASE.variant_params('default')
    assert not defect_uncaught(CASE, p, defect, "rk4", 4, CASE.dts(p)), defect


@pytest.mark.parametrize("defect", ["gravity_plus_0.1pct", "rest_length_plus_0.5pct",
                                    "velocity_damping"])
def test_a_wrong_parameter_exceeds_the_rk4_bound_at_the_finest_dt(defect):
    p = CASE.variant_params('default')
    assert not defect_uncaught(CASE, p, defect, "rk4", 4, [min(CASE.dts(p))]), defect


def test_a_velocity_verlet_that_is_explicit_euler_exceeds_the_verlet_bound_at_every_dt():
    """refsim's rigid group offers no velocity Verlet; its explicit Euler rows stand for an
    engine whose "velocity_verlet" is explicit Euler: every one errs above Verlet's bound."""
    p = CASE.variant_params('default')
    assert not defect_uncaught(CASE, p, "control", "explicit_euler", 2, CASE.dts(p),
                               named="velocity_verlet")
