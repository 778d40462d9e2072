"""advection_vortex: every stepper's run equals its exact discrete solution to round-off, the
radius grows by |R(iy)| a step, and the errors against the flow converge at the nominal order."""
import numpy as np
import pytest

from refsim_adapters.planted_defects.checks import job_uncaught
from refsim_cases.first_order_fields.advection_vortex import AXIS, CASE, CENTRE
from refsim.engine import Engine
from refsim.integrators.first_order import get_first_order
from refsim.integrators.tableaux import RK4
from refsim import registry
from refsim.run.job import Job, run_job
from refsim.models.advection import vortex_radius_factor

FIELD_STEPPERS = ("explicit_euler", "midpoint", "heun", "rk4", "implicit_euler")


@pytest.mark.parametrize("integrator", FIELD_STEPPERS)
def test_error_is_the_exact_discrete_deviation(integrator):
    """err_max against the flow equals the exact discrete deviation to round-off: within the
    tolerance's round-off term of it, from both sides."""
    p, dt = CASE.variant_params("default", {"particles": 50}), 0.1
    row = run_job(Job(CASE.name, "default", "refsim", "", integrator, dt,
                      params=(("particles", 50),)), repeats=0)
    deviation, _ = CASE.discrete_deviation(p, integrator, dt)
    roundoff = row["tolerance"] - deviation
    assert row["status"] == "ok" and (row["consistency"] == "consistent")
    assert abs(row["err_max"] - deviation) <= roundoff


@pytest.mark.parametrize("integrator", FIELD_STEPPERS)
def test_radius_growth_rate(integrator):
    """ln(r_k / r_0) / t = ln|R(iy)| / h to round-off: each step rounds r by <= 4 eps
    relative (the stages' sums), so ln r drifts by <= 4 k eps, the rate (divided by t = k h)
    by <= 4 eps / h; doubled for the radius and the log's own rounding."""
    p, dt = CASE.variant_params("default", {"particles": 50}), 0.1
    row = run_job(Job(CASE.name, "default", "refsim", "", integrator, dt,
                      params=(("particles", 50),)), repeats=0)
    want = np.log(vortex_radius_factor(get_first_order(integrator), dt * p["omega"])) / dt
    assert abs(row["radius_growth_rate"] - want) <= 8 * np.finfo(float).eps / dt


def test_second_order_steppers_refused_with_a_reason():
    scene = CASE.scene(CASE.variant_params("default"))
    engine = registry.get_engine("refsim")
    reason = engine.supports(scene, "symplectic_euler")
    assert reason is not None and "first-order system p' = u(p)" in reason
    assert engine.supports(scene, "rk4") is None
    assert isinstance(engine, Engine)


def test_case_contract():
    p = CASE.variant_params("default")
    assert CASE.order_meaningful and min(CASE.dts(p)) > max(CASE.order_dts(p))
    assert max(CASE.dts(p)) / min(CASE.order_dts(p)) >= 10  # a decade for the order fit
    assert np.allclose(np.linalg.norm(AXIS), 1.0) and len(CENTRE) == 3


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
