"""gradient_descent: the exact contraction 1 - h lambda per step (and R(-h lambda) for every
stepper), stability iff h < 2/lambda for explicit Euler."""
import numpy as np
import pytest

from refsim_adapters.planted_defects.checks import job_uncaught
from refsim_cases.first_order_fields.gradient_descent import CASE
from refsim.integrators.first_order import get_first_order
from refsim.integrators.tableaux import RK4
from refsim.run.job import Job, run_job

FIELD_STEPPERS = ("explicit_euler", "midpoint", "heun", "rk4", "implicit_euler")


def test_euler_contraction_is_one_minus_h_lambda():
    """Forward Euler's factor per step is 1 - h lambda exactly: R(z) = 1 + z."""
    stepper, h = get_first_order("explicit_euler"), 0.013
    lam = np.array(CASE.rates(CASE.variant_params("default")))
    # exact: R(z) = 1 z^0 + 1 z^1 with z^0 = 1, z^1 = z; 1 + (-(h lam)) rounds as 1 - h lam
    assert np.all(stepper.stability(-h * lam).real == 1.0 - h * lam)
    implicit = get_first_order("implicit_euler").stability(-h * lam).real
    assert np.allclose(implicit, 1.0 / (1.0 + h * lam), rtol=4 * np.finfo(float).eps)


@pytest.mark.parametrize("integrator", FIELD_STEPPERS)
def test_run_matches_the_exact_discrete_solution(integrator):
    p, dt = CASE.variant_params("default"), CASE.dts(CASE.variant_params("default"))[0]
    row = run_job(Job(CASE.name, "default", "refsim", "", integrator, dt), repeats=0)
    deviation, _ = CASE.discrete_deviation(p, integrator, dt)
    assert row["status"] == "ok" and (row["consistency"] == "consistent")
    assert abs(row["err_max"] - deviation) <= row["tolerance"] - deviation
    rate = np.log(abs(get_first_order(integrator).stability(-dt * CASE.rates(p)[0]))) / dt
    # each step rounds p_1 by <= 2 eps |p| <= 2 eps S (S = max |p|), relative to the final
    # offset d >= |R|^k d_0: ln d errs by <= k 2 eps S / d, the rate (/ k h) by 2 eps S / (h d)
    rel = CASE.relative_start(p)[:, 0]
    steps = round(CASE.t_end(p) / dt)
    final = np.max(np.abs(rel)) * abs(get_first_order(integrator).stability(
        -dt * CASE.rates(p)[0])) ** steps
    bound = 2 * np.finfo(float).eps * np.max(np.abs(CASE.start(p))) / (dt * final)
    assert abs(row["contraction_rate_slow_axis"] - rate) <= bound


def test_stable_iff_h_below_two_over_lambda():
    """At h lambda_max = 2.5 (variant unstable): |1 - 2.5| > 1, explicit Euler, midpoint and
    Heun (|1 - 2.5 + 3.125| > 1) diverge; RK4 (|R(-2.5)| = 0.65) and implicit Euler converge."""
    p = CASE.variant_params("unstable")
    dt = CASE.dts(p)[0]
    assert np.isclose(dt * CASE.rates(p)[2], 2.5)
    for integrator, stable in (("explicit_euler", False), ("midpoint", False), ("heun", False),
                               ("rk4", True), ("implicit_euler", True)):
        factor = abs(get_first_order(integrator).stability(-dt * CASE.rates(p)[2]))
        assert (factor < 1) == stable
        row = run_job(Job(CASE.name, "unstable", "refsim", "", integrator, dt), repeats=0)
        assert (row["status"] == "ok") == stable, (integrator, row["status"], row["reason"])
    below = 0.999 * 2.0 / CASE.rates(p)[2]
    assert abs(get_first_order("explicit_euler").stability(-below * CASE.rates(p)[2])) < 1


# -- planted defects: a wrong method exceeds the named method's exact bound --------------------
@pytest.mark.parametrize("defect", ["planted_heun_as_rk4", "planted_rk3_as_rk4"])
def test_a_wrong_method_exceeds_the_named_methods_bound(planted, defect):
    """At every dt of the sweep (measured: Heun 2e3 .. 2e5 x, Kutta's RK3 50 .. 500 x RK4's
    exact bound)."""
    assert not job_uncaught(CASE, "default", defect, "rk4", 4), defect


def test_exact_part_is_the_rk_step_matrix_of_the_tableau(rk_step_deviation):
    """The tolerance's exact part, from refsim.models.advection's stability factors, equals the
    explicit RK step matrix on p' = M (p - c) written from the tableau (refsim.expected's
    _rk_matrix) to 1e-12 relative."""
    p = CASE.variant_params("default", {"particles": 20})
    dt = CASE.dts(p)[0]
    worst = rk_step_deviation(CASE, p, dt, RK4)
    assert CASE.discrete_deviation(p, "rk4", dt)[0] == pytest.approx(worst, rel=1e-12)
