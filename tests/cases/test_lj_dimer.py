"""LJ dimer: k = U''(r0) = 36 2^(2/3) eps/sigma^2, the quadrature period -> 2 pi / w0 with the
Lindstedt-Poincare A^2 shift, the converged reference returns to r_max after that period, and a
refsim run measures the period and conserves momentum."""
import math

import numpy as np
import pytest

from refsim_cases.lennard_jones.lj_dimer import (CASE, K_REDUCED, R0_OVER_SIGMA, crossing_times,
                                            curvature, exact_period, force, potential,
                                            reference_separation, small_vibration_omega,
                                            turning_points)
from refsim_adapters.planted_defects.checks import bound_misfits, job_uncaught, sweep
from refsim import registry
from refsim.testing import accuracy, measured_order

EPS = np.finfo(float).eps


@pytest.fixture(scope="module", autouse=True)
def registered():
    if "lj_dimer" not in registry.names("case"):
        registry.register("case", "lj_dimer", "refsim_cases.lennard_jones.lj_dimer:CASE")


def test_stiffness_is_36_two_to_two_thirds():
    assert K_REDUCED == pytest.approx(57.146, abs=5e-4)  # the slide's value, 5 digits
    assert float(curvature(R0_OVER_SIGMA, 1.0, 1.0)) == pytest.approx(K_REDUCED, rel=1e-14)
    h = 1e-4  # central second difference: h^2 U''''(r0)/12, U''''(r0) = 16832; rounding 4 eps / h^2
    fd = (potential(R0_OVER_SIGMA + h, 1, 1) - 2 * potential(R0_OVER_SIGMA, 1, 1)
          + potential(R0_OVER_SIGMA - h, 1, 1)) / h ** 2
    assert float(fd) == pytest.approx(K_REDUCED, abs=h * h * 1.7e4 / 12 + 4 * EPS / h ** 2)
    assert small_vibration_omega(1.0, 1.0, 1.0) == pytest.approx(math.sqrt(2 * K_REDUCED),
                                                                 rel=1e-15)


def _lindstedt_shift():
    """T/T0 - 1 = -(3 beta / (8 w0^2) - 5 alpha^2 / (12 w0^4)) A^2 + O(A^3) for
    x'' + w0^2 x + alpha x^2 + beta x^3 = 0 (Landau & Lifshitz, Mechanics, sec. 28), with
    alpha = U'''/(2 mu), beta = U''''/(6 mu) at r0 (mu = 1/2; (s/r0)^6 = 1/2 there)."""
    r0, mu = R0_OVER_SIGMA, 0.5
    u3 = 4 * (-2184 * 0.25 + 336 * 0.5) / r0 ** 3
    u4 = 4 * (32760 * 0.25 - 3024 * 0.5) / r0 ** 4
    alpha, beta, w2 = u3 / (2 * mu), u4 / (6 * mu), K_REDUCED / mu
    return -(3 * beta / (8 * w2) - 5 * alpha ** 2 / (12 * w2 ** 2))


def test_quadrature_period_tends_to_harmonic_with_the_lindstedt_shift():
    t0 = 2 * math.pi / small_vibration_omega(1.0, 1.0, 1.0)
    c2 = _lindstedt_shift()
    assert c2 > 0  # the LJ well softens outward: larger swings are slower
    residual = [(exact_period(a, 1.0, 1.0, 1.0) / t0 - 1.0) / a ** 2 - c2
                for a in (4e-3, 2e-3, 1e-3)]
    # the next term is O(A): halving A halves the residual (ratio 2 to O(A) = 1e-3, far above
    # quad's 1e-13 relative error / A^2 = 1e-7 of c2)
    assert residual[0] / residual[1] == pytest.approx(2.0, rel=0.02)
    assert residual[1] / residual[2] == pytest.approx(2.0, rel=0.02)


@pytest.mark.parametrize("amplitude", [0.01, 0.1, 0.3])
def test_reference_returns_to_r_max_after_the_quadrature_period(amplitude):
    # in units eps = sigma = m = 1 (the defaults are not 1); t_end > 2 T(A)
    p = CASE.validate({"amplitude": amplitude, "periods": 5.0, "epsilon": 1.0, "sigma": 1.0,
                       "mass": 1.0})
    period = exact_period(amplitude, 1.0, 1.0, 1.0)
    r, rdot = reference_separation(p, np.array([0.0, period, 2 * period]))
    r_min, r_max = turning_points(amplitude, 1.0, 1.0)
    # DOP853 at rtol 1e-13 over 3 periods; at a turning point r - r_max ~ r'' dt^2 / 2 so a
    # timing error dT shows only as r'' dT^2: bound the velocity instead, |r'| <= r'' dT with
    # dT = 1e-11 T (quad to 1e-13, the integration to 1e-11 after ~100 steps of rtol 1e-13)
    accel = float(-K_REDUCED * amplitude / 0.5) * 2  # |r''| at r_max, bounded by twice the
    assert np.max(np.abs(rdot)) <= abs(accel) * 1e-11 * period + 1e-11  # harmonic value
    assert np.max(np.abs(r - r_max)) <= 1e-11
    # brentq locates r_min to xtol + rtol r_min = 1e-15 + 4 eps r_min: U differs by |U'| that
    slope = abs(float(force(r_min, 1.0, 1.0)))
    assert float(potential(r_min, 1, 1)) == pytest.approx(
        float(potential(r_max, 1, 1)), abs=slope * (1e-15 + 4 * EPS * r_min) + 4 * EPS)


def test_crossing_times_of_a_sine_are_exact_to_interpolation_order():
    t = np.linspace(0.0, 10.0, 401)
    times = crossing_times(t, np.sin(t), np.cos(t), 0.0)
    # cubic Hermite: O(h^4) = (0.025)^4 / 384 ~ 1e-9 in the root
    assert np.allclose(times, 2 * math.pi * np.arange(1, 2), atol=1e-9)


def test_refsim_run_measures_the_period_and_conserves_momentum():
    p = CASE.variant_params("large")
    row = accuracy("lj_dimer", "large", "refsim", "velocity_verlet", CASE.reference_dt(p))
    assert row["status"] == "ok" and (row["consistency"] == "consistent"), row["tol_reason"]
    # Verlet's phase error after 2 periods is ~ (w dt)^2 / 24 relative: (0.08)^2/24 = 3e-4
    assert row["period_error"] <= (2 * math.pi / 80) ** 2 / 24 * 1.5
    assert row["period_shift"] > 0
    # momentum starts at 0; each step's rounding of the two opposite forces: n eps |F| dt / m
    assert row["momentum_drift"] <= row["steps"] * EPS * 10.0


def test_velocity_verlet_order_is_two():
    p = CASE.variant_params("small")
    order, used, _ = measured_order("lj_dimer", "small", "refsim", "velocity_verlet",
                                    CASE.dts(p))
    # error c2 dt^2 (1 + O((w dt)^2)): at w dt <= 0.31 the slope is 2 within (0.31)^2 ~ 0.1
    assert order == pytest.approx(2.0, abs=0.1) and used == 3


# -- the bound: twice the exact discrete error on the harmonic dimer ---------------------------
P = CASE.variant_params("small")
SWEEP = sweep(CASE, P)


@pytest.mark.parametrize("variant", ["small", "large"])
@pytest.mark.parametrize("integrator", ["explicit_euler", "symplectic_euler", "rk4",
                                        "velocity_verlet"])
def test_refsim_within_its_bound_and_the_bound_is_tight(variant, integrator):
    """error <= bound <= 3 x error at every dt of the sweep where the bound resolves the
    motion (measured 1.9 .. 2.1 at A = 0.01 sigma; 1.2 .. 2.7 at 0.1 sigma)."""
    p = CASE.variant_params(variant)
    assert not bound_misfits(CASE, variant, integrator, sweep(CASE, p), 3.0,
                             resolved_only=True), (variant, integrator)


def test_harmonic_error_of_velocity_verlet_is_its_phase_error():
    """From rest, velocity Verlet's x_k = A cos(k theta) exactly, cos theta = 1 - y^2/2: the
    error is A |cos(k theta) - cos(k y)| (checked to 1e-9 relative)."""
    dt = CASE.reference_dt(P)
    w, a = CASE.omega0(P), P["amplitude"]
    k = CASE.sampled_steps(P, dt)
    theta = np.arccos(1 - (w * dt) ** 2 / 2)
    expected = np.max(np.abs(a * (np.cos(k * theta) - np.cos(k * w * dt))))
    assert CASE.harmonic_error(P, "velocity_verlet", dt) == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("defect,integrator,order", [
    ("planted_heun_as_rk4", "rk4", 4), ("planted_rk3_as_rk4", "rk4", 4),
    ("planted_euler_as_verlet", "velocity_verlet", 2)])
def test_a_wrong_method_exceeds_the_named_methods_bound(planted, defect, integrator, order):
    assert not job_uncaught(CASE, "small", defect, integrator, order, SWEEP,
                            floor=CASE.error_floor(P)), defect


@pytest.mark.parametrize("integrator,order", [("rk4", 4), ("velocity_verlet", 2)])
def test_velocity_damping_is_caught_at_the_finest_dt(planted, integrator, order):
    assert not job_uncaught(CASE, "small", "planted_velocity_damping", integrator, order,
                            SWEEP[:1])
