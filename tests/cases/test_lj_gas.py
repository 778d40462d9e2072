"""2D LJ gas: the start has zero momentum and kinetic energy (N - 1) T exactly, the box obeys
the minimum-image rule, momentum is conserved to round-off over a run, and velocity Verlet's
energy error converges at order 2 on the fixed horizon (explicit Euler's at order 1)."""
import numpy as np
import pytest

from refsim_cases.lennard_jones.lj_gas import CASE, lattice_start, thermal_omega
from refsim_adapters.planted_defects.checks import bound_misfits, job_uncaught, sweep
from refsim import registry
from refsim.scene.lennard_jones import LennardJones
from refsim.testing import accuracy, measured_order

EPS = np.finfo(float).eps


@pytest.fixture(scope="module", autouse=True)
def registered():
    if "lj_gas" not in registry.names("case"):
        registry.register("case", "lj_gas", "refsim_cases.lennard_jones.lj_gas:CASE")


def test_start_has_zero_momentum_and_exact_temperature():
    x, v, side = lattice_start(1000, 0.7, 1.0, 1)  # m = 1 (the default argument)
    assert side == pytest.approx(np.sqrt(1000 / 0.7), rel=1e-15)
    assert np.all((x[:, :2] > 0) & (x[:, :2] < side)) and np.all(x[:, 2] == 0)
    # zero mean to round-off of a 1000-term sum of O(1) speeds, then scaled by ~1
    assert np.max(np.abs(v.sum(axis=0))) <= 1000 * EPS * 4
    assert 0.5 * np.sum(v * v) == pytest.approx(999 * 1.0, rel=1e-14)
    spacing = np.min(np.linalg.norm(x[1:, :2] - x[:-1, :2], axis=1))
    assert spacing > 1.0  # no overlapping cores at the start


def test_thermal_collision_turns_where_u_equals_t():
    w = thermal_omega(1.0)
    s6 = 0.5 * (1 + np.sqrt(2.0))
    assert 4 * (s6 * s6 - s6) == pytest.approx(1.0, rel=1e-14)
    assert w > np.sqrt(2 * 36 * 2 ** (2 / 3))  # stiffer than the well's bottom


def test_scene_box_obeys_minimum_image_rule():
    p = CASE.variant_params("default")
    part = CASE.scene(p).part(LennardJones)
    assert part.box[0] >= 2 * part.cutoff and part.shift and CASE.scene(p).dim == 2


def test_momentum_is_conserved_to_round_off():
    row = accuracy("lj_gas", "default", "refsim", "velocity_verlet", 5e-3, particles=200.0,
                   duration=0.5)
    assert row["status"] == "ok" and (row["consistency"] == "consistent"), row["tol_reason"]
    # each step adds to sum m v the rounding of N force sums (|F| <= ~100 eps/sigma each, the
    # pair force's two bincounts round independently): steps x N x eps x 100 x dt, x 10 margin
    # for the kick's two half steps and the initial sum
    bound = row["steps"] * 200 * EPS * 100 * 5e-3 * 10 + 200 * EPS * 4
    assert row["momentum_drift"] <= bound


@pytest.mark.parametrize("integrator, nominal", [("velocity_verlet", 2.0),
                                                 ("explicit_euler", 1.0)])
def test_energy_error_order_on_a_fixed_horizon(integrator, nominal):
    p = CASE.variant_params("default")
    # the default N = 1000 (at N = 200, m = 2, velocity Verlet's bounded energy oscillation
    # bends the fit to 2.33: too few collisions to average it)
    order, used, errs = measured_order("lj_gas", "default", "refsim", integrator,
                                       CASE.dts(p) + CASE.order_dts(p))
    # the energy error c dt^p (1 + O(w_T dt)): at w_T dt <= 0.39 the slope is p to ~0.2
    assert used == len(errs) and order == pytest.approx(nominal, abs=0.2), errs


# -- the bound: twice the first-order energy error of the named method -------------------------
P = CASE.variant_params("default")
SWEEP = sweep(CASE, P)


@pytest.mark.parametrize("integrator", ["explicit_euler", "symplectic_euler", "rk4",
                                        "velocity_verlet"])
def test_refsim_within_its_bound_and_the_bound_is_tight(integrator):
    """error <= bound <= 2.5 x error at every dt of the sweep (measured 1.99 .. 2.0)."""
    assert not bound_misfits(CASE, "default", integrator, SWEEP, 2.5), integrator


@pytest.mark.parametrize("defect,integrator,order", [
    ("planted_heun_as_rk4", "rk4", 4), ("planted_rk3_as_rk4", "rk4", 4),
    ("planted_euler_as_verlet", "velocity_verlet", 2)])
def test_a_wrong_method_exceeds_the_named_methods_bound(planted, defect, integrator, order):
    assert not job_uncaught(CASE, "default", defect, integrator, order, SWEEP,
                            floor=CASE.error_floor(P)), defect


@pytest.mark.parametrize("integrator,order", [("rk4", 4), ("velocity_verlet", 2)])
def test_velocity_damping_is_caught_at_the_finest_dt(planted, integrator, order):
    assert not job_uncaught(CASE, "default", "planted_velocity_damping", integrator, order,
                            SWEEP[:1])
