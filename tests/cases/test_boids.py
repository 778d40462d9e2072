"""Boids case: the converged reference, flocking against Ha & Liu's bound, the figure."""
import numpy as np
import pytest

from refsim_adapters.planted_defects.checks import bound_misfits, job_uncaught, sweep
from refsim_cases.flocking.boids import CASE
from refsim.models.flocking import velocity_variance


def test_reference_keeps_the_mean_velocity_and_flocks_within_the_bound():
    p = CASE.variant_params("cucker_smale")
    t = np.linspace(0.0, CASE.t_end(p), 21)
    ref = CASE.reference(p, t)
    x0, v0 = CASE.initial_state(p)
    assert np.abs(ref["x"][0] - x0).max() <= 1e-12 * np.abs(x0).max()
    var = ref["velocity_variance"]
    assert np.all(np.diff(var) < 0)  # d|V|^2/dt <= -2 psi(D) |V|^2 < 0
    # the flow's bound, met by a solution accurate to rtol = 1e-12 (relative)
    assert np.all(var[1:] <= CASE.variance_bound(p, t[1:]) * (1 + 1e-9))
    assert var[-1] < 0.1 * var[0]


def test_figure_is_the_bound_curve():
    p = CASE.variant_params("cucker_smale")
    (figure,) = CASE.figures(p)
    assert figure["y"] == "velocity_variance" and figure["x"] == "t"
    # same operations: the bound at t = 0 is velocity_variance(v0) times exp(-0) = 1, twice
    assert figure["data"]["y"][0] == velocity_variance(CASE.initial_state(p)[1])


def test_reynolds_variant_has_no_bound_figure():
    assert CASE.figures(CASE.variant_params("reynolds")) == []


# -- the bound: the exact discrete solution of the named method on the frozen linear flow ----

P = CASE.variant_params("cucker_smale")
SWEEP = sweep(CASE, P)


@pytest.mark.parametrize("integrator", ["explicit_euler", "symplectic_euler", "heun", "rk4",
                                        "dopri5", "velocity_verlet", "leapfrog"])
def test_refsim_within_its_bound_and_the_bound_is_tight(integrator):
    """Every dt of the sweep: error <= bound <= 5 x error (measured 1.9 .. 4.7: the safety
    factor 2, and the reference's error where the error is at the floor)."""
    assert not bound_misfits(CASE, "cucker_smale", integrator, SWEEP, 5.0), integrator


@pytest.mark.parametrize("defect,integrator,named,order", [
    ("planted_heun_as_rk4", "rk4", "rk4", 4), ("planted_rk3_as_rk4", "rk4", "rk4", 4),
    ("planted_euler_as_verlet", "velocity_verlet", "velocity_verlet", 2)])
def test_a_wrong_method_exceeds_the_named_methods_bound(planted, defect, integrator, named,
                                                        order):
    assert not job_uncaught(CASE, "cucker_smale", defect, integrator, order, SWEEP, named=named,
                            floor=CASE.error_floor(P)), defect


def test_velocity_damping_is_caught_at_the_finest_dt(planted):
    assert not job_uncaught(CASE, "cucker_smale", "planted_velocity_damping", "rk4", 4, SWEEP[:1])


def test_frozen_error_is_the_discrete_solution_of_the_full_linear_system():
    """The modal computation equals refsim.expected.discrete_solution on the whole (x, v)
    system x'' = B v (one coordinate at a time) to a relative 1e-8."""
    from scipy.linalg import expm

    from refsim_cases.flocking.boids import alignment_laplacian, frozen_error
    from refsim.expected import discrete_solution
    x0, v0 = CASE.initial_state(P)
    n, dt = len(x0), 0.04
    b = alignment_laplacian(P, x0)
    jac = np.block([[np.zeros((n, n)), np.eye(n)], [np.zeros((n, n)), b]])
    steps = int(round(CASE.t_end(P) / dt))
    stride = max(1, int(round(CASE.sample_dt(P) / dt)))
    ks = np.unique(np.append(np.arange(0, steps + 1, stride), steps))
    sq = np.zeros(len(ks))
    for c in range(3):
        xd, _ = discrete_solution("heun", np.zeros((n, n)), b, x0[:, c], v0[:, c], dt, ks)
        exact = np.array([(expm(jac * k * dt) @ np.r_[x0[:, c], v0[:, c]])[:n] for k in ks])
        sq += np.sum((xd - exact) ** 2, axis=1)
    assert np.isclose(frozen_error(P, "heun", dt), np.sqrt(sq.max()), rtol=1e-8)
