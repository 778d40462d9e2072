"""wave_mode: every scheme follows its closed-form discrete solution to round-off; leapfrog
obeys the discrete dispersion relation and is exact at C = 1 in 1D; orders in dt; the Courant
limits 1 and 1/sqrt 2 measured by `refsim stress`."""
import math

import numpy as np
import pytest

from refsim_cases.grid_evolution.wave_mode import CASE, discrete_u
from refsim.registry import get_engine
from refsim.run.job import Job, run_job

ENGINE = get_engine("refsim")
SCHEMES = ["stormer_verlet", "velocity_verlet", "symplectic_euler", "rk4", "implicit_euler",
           "implicit_midpoint"]
EPS = np.finfo(float).eps


def _u(p, integrator, dt, steps):
    sim = ENGINE.build(CASE.scene(p), dt, integrator, "")
    sim.step(steps)
    return sim.observe()["grid.u"]


@pytest.mark.parametrize("variant", ["1d", "2d"])
@pytest.mark.parametrize("integrator", SCHEMES)
def test_each_scheme_is_its_closed_form_discrete_solution(variant, integrator):
    p = CASE.variant_params(variant)
    dt, steps = CASE.dt_of(p, 0.5), 50
    u = _u(p, integrator, dt, steps)
    oracle = discrete_u(integrator, CASE.omega_h(p), dt, [steps])[0] * CASE.grid(p).mode()
    # n steps, each rounding by a few eps of the amplitude (stencil terms scaled by C^2)
    assert np.max(np.abs(u - oracle)) <= 4 * steps * (1 + 4 * p["dim"] * 0.25) * EPS * 4


def test_leapfrog_dispersion_relation_sin_half_w_dt_equals_c_sin_half_theta():
    p = CASE.variant_params("1d")
    g, courant = CASE.grid(p), 0.5
    dt = CASE.dt_of(p, courant)
    w_tilde = 2 / dt * math.asin(courant * math.sin(g.wave * g.h / 2))
    steps = 37
    u = _u(p, "stormer_verlet", dt, steps)
    assert np.max(np.abs(u - math.cos(w_tilde * steps * dt) * g.mode())) <= 50 * steps * EPS


def test_leapfrog_is_exact_at_courant_one_in_1d():
    p = CASE.variant_params("1d")
    row = run_job(Job("wave_mode", "1d", "refsim", "", "stormer_verlet", CASE.dt_of(p, 1.0)),
                  repeats=0)
    assert row["err_continuum"] <= 64 * 10 * EPS  # 64 steps, round-off only


@pytest.mark.parametrize("integrator,order", [("stormer_verlet", 2), ("symplectic_euler", 1),
                                              ("implicit_midpoint", 2), ("rk4", 4),
                                              ("implicit_euler", 1)])
def test_time_error_has_the_scheme_order(integrator, order):
    p = CASE.variant_params("1d")
    courants = [0.25, 0.125, 0.0625]
    err = [run_job(Job("wave_mode", "1d", "refsim", "", integrator, CASE.dt_of(p, c)),
                   repeats=0)["err_max"] for c in courants]
    slopes = np.diff(np.log(err)) / np.diff(np.log(courants))
    assert np.all(np.abs(slopes - order) < 0.1), slopes


@pytest.mark.parametrize("variant,limit", [("1d", 1.0), ("2d", 1 / math.sqrt(2))])
def test_stress_measures_the_courant_limit(variant, limit, stress_limits):
    table = stress_limits("wave_mode", variant, ["stormer_verlet", "implicit_midpoint"])
    assert table.loc["stormer_verlet", "theory"] == pytest.approx(limit, rel=1e-12)
    assert table.loc["stormer_verlet", "agrees"]
    assert math.isinf(table.loc["implicit_midpoint", "measured"])
