"""Emitter case: its reference counts and the tolerances it derives."""
import numpy as np
import pytest

from refsim_adapters.planted_defects.checks import job_error, job_uncaught
from refsim_cases.emitter.sprinkler import CASE
from refsim.models import emitter as em
from ulp import assert_ulp


def test_reference_counts_are_rate_times_time():
    p = CASE.variant_params("default")
    t = np.linspace(0.0, p["duration"], 401)
    ref = CASE.reference(p, t)
    # alive: rate x min(t, lifetime), to one particle (the floor of each end)
    assert np.all(np.abs(ref["alive"] - p["rate"] * np.minimum(t, p["lifetime"])) <= 1.0)
    # exact: integer-valued doubles
    assert ref["emitted"][-1] == p["rate"] * p["duration"] + 1


def test_first_order_tolerance_is_the_exact_lag_plus_round_off():
    p = CASE.variant_params("default")
    tol_euler, _ = CASE.tolerance(p, "explicit_euler", 1, 0.01)
    tol_rk4, reason = CASE.tolerance(p, "rk4", 4, 0.01)
    # (lag + roundoff) - roundoff is not the same arithmetic as lag: the sum rounds once and
    # the difference once more, each by half an ulp of lag (roundoff < 1e-11 << lag): 1 ulp
    assert_ulp(tol_euler - tol_rk4, 0.5 * p["g"] * 0.01 * p["lifetime"], 1,
               "the first-order lag added to the round-off term, then subtracted back")
    assert tol_rk4 < 1e-11 and "round-off" in reason
    assert CASE.order_meaningful is False
    # floor(rate L h) + 1 with L h = lifetime = 0.5 s (h divides it): 25 + 1
    assert em.capacity(CASE.emitter(p), 0.01) == 26


# -- planted defects (the "corrected" formulation) ---------------------------------------------
def test_euler_as_verlet_exceeds_the_verlet_bound_at_every_dt(planted):
    p = CASE.variant_params("default")
    assert not job_uncaught(CASE, "default", "planted_euler_as_verlet", "velocity_verlet", 2,
                            CASE.dts(p), formulation="corrected")


@pytest.mark.parametrize("defect", ["planted_gravity_plus_0.1pct", "planted_velocity_damping"])
@pytest.mark.parametrize("integrator,order", [("rk4", 4), ("velocity_verlet", 2)])
def test_model_defects_are_caught_at_the_finest_dt(planted, defect, integrator, order):
    p = CASE.variant_params("default")
    assert not job_uncaught(CASE, "default", defect, integrator, order, [min(CASE.dts(p))],
                            formulation="corrected")


def test_heun_as_rk4_is_exact_here_too(planted):
    """What this case cannot catch: every method of order >= 2 is exact on a parabola (constant
    acceleration), so Heun run as rk4 stays within RK4's round-off bound (measured 7.8e-15 m
    against 8.7e-14 m at 5 ms)."""
    p = CASE.variant_params("default")
    assert job_error(CASE.name, "default", "planted_heun_as_rk4", "rk4", 0.005, "corrected") <= \
        CASE.tolerance(p, "rk4", 4, 0.005)[0]
