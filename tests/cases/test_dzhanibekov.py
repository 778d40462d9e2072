"""The Dzhanibekov closed form against a DOP853 solve of Euler's equations, its invariants and
flip period, and the case's reading of an observation (frames, momentum, energy)."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from refsim_adapters.planted_defects.checks import defect_error, defect_uncaught
from refsim_cases.rigid import quat_multiply, quat_to_matrix
from refsim_cases.rigid.dzhanibekov import (CASE, exact_body_omega, flip_period, initial_body_omega,
                                     initial_orientation, invariants, moments, world_momentum)
from refsim.scene import RigidBodies

RTOL = 1e-12  # the DOP853 reference solve of the brief
VARIANTS = list(CASE.variants)


def _euler_rhs(inertia):
    i1, i2, i3 = inertia

    def rhs(_, state):
        """Euler's equations in the body frame and q' = 1/2 q (x) (0, w_body)."""
        w, q = state[:3], state[3:]
        dw = [(i2 - i3) * w[1] * w[2] / i1, (i3 - i1) * w[2] * w[0] / i2,
              (i1 - i2) * w[0] * w[1] / i3]
        return np.concatenate([dw, 0.5 * quat_multiply(q, np.r_[0.0, w])])
    return rhs


def _solve(p, t, **kwargs):
    state0 = np.concatenate([initial_body_omega(p), initial_orientation()])
    return solve_ivp(_euler_rhs(moments(p)), (0.0, t[-1]), state0, method="DOP853", rtol=RTOL,
                     atol=RTOL * 1e-2, t_eval=t, **kwargs)


def _adaptive_bound(p):
    """The case's own bound for an adaptive solve at rtol 1e-12: 10 rtol |w0| W t times the
    flip-timing amplification 1 + S rate t (the closed form's ellipj round-off, ~1e-15 per
    evaluation, is far below it)."""
    return CASE.tolerance(p, f"dopri5_adaptive:{RTOL}", 8, 0.0)[0]


@pytest.mark.parametrize("variant", VARIANTS)
def test_closed_form_matches_dop853_solve_of_euler_equations(variant):
    p = CASE.variant_params(variant)
    t = np.linspace(0.0, CASE.t_end(p), 801)
    sol = _solve(p, t)
    err = np.max(np.linalg.norm(sol.y[:3].T - exact_body_omega(p, t), axis=1))
    assert err < _adaptive_bound(p)
    # the flip happens: w2 goes from +W to -W and back within the run
    assert sol.y[1].min() < -0.99 * p["spin"] and sol.y[1][-1] > 0.99 * p["spin"]


@pytest.mark.parametrize("variant", VARIANTS)
def test_flip_times_are_k_and_3k_over_rate_and_period_is_4k_over_rate(variant):
    p = CASE.variant_params(variant)
    c = invariants(p)
    crossing = lambda _, state: state[1]  # noqa: E731 - w2 = 0: the flip's midpoint
    sol = _solve(p, np.array([0.0, CASE.t_end(p)]), events=crossing)
    flips = sol.t_events[0]
    # an error dw in w2 moves its zero by dw / |dw2/dt|, |dw2/dt| = A2 rate at sn = 0
    time_tol = _adaptive_bound(p) / (c["amplitudes"][1] * c["rate"])
    np.testing.assert_allclose(flips, [c["K"] / c["rate"], 3 * c["K"] / c["rate"]],
                               rtol=0, atol=time_tol)
    assert flip_period(p) == pytest.approx(4 * c["K"] / c["rate"], rel=1e-15)
    t = np.linspace(0.0, flip_period(p), 50)
    # periodic to the round-off of u = rate t + K reduced modulo 4K (a few eps of 4K)
    np.testing.assert_allclose(exact_body_omega(p, t + flip_period(p)),
                               exact_body_omega(p, t), rtol=0, atol=1e-12)


@pytest.mark.parametrize("variant", VARIANTS)
def test_energy_and_momentum_norm_are_constant_along_the_closed_form(variant):
    p = CASE.variant_params(variant)
    c, inertia = invariants(p), moments(p)
    w = exact_body_omega(p, np.linspace(0.0, CASE.t_end(p), 2001))
    energy = 0.5 * np.sum(inertia * w * w, axis=1)
    momentum2 = np.sum((inertia * w) ** 2, axis=1)
    # sn^2 + cn^2 = 1 and dn^2 + m sn^2 = 1 hold to a few eps in scipy's ellipj
    np.testing.assert_allclose(energy, c["E"], rtol=1e-13)
    np.testing.assert_allclose(momentum2, c["L2"], rtol=1e-13)


@pytest.mark.parametrize("variant", VARIANTS)
def test_closed_form_starts_at_the_initial_state_near_the_intermediate_axis(variant):
    p = CASE.variant_params(variant)
    w0 = initial_body_omega(p)
    np.testing.assert_allclose(exact_body_omega(p, [0.0])[0], w0, rtol=0, atol=1e-14)
    assert invariants(p)["m"] == pytest.approx(p["k2"], rel=1e-12)
    assert w0[0] == 0.0 and w0[1] == p["spin"] and 0 < w0[2] < w0[1]


def test_scene_puts_no_body_axis_on_a_world_axis_and_gives_world_angular_velocity():
    p = CASE.variant_params("far")
    rigid = CASE.scene(p).part(RigidBodies)
    rotation = quat_to_matrix(rigid.orientation[0])
    assert np.max(np.abs(rotation)) < np.cos(np.radians(10))  # every axis >= 10 deg off
    np.testing.assert_allclose(rigid.angular_velocity[0], rotation @ initial_body_omega(p))
    np.testing.assert_allclose(rigid.inertia[0], np.diag(moments(p)))


def _observation(p, n=401):
    """An exact engine observation built from the DOP853 solve (q, world w), shape (T, 1, .)."""
    t = np.linspace(0.0, CASE.t_end(p), n)
    sol = _solve(p, t)
    q = sol.y[3:].T / np.linalg.norm(sol.y[3:].T, axis=1, keepdims=True)
    w_world = np.einsum("tij,tj->ti", quat_to_matrix(q), sol.y[:3].T)
    return {"t": t, "q": q[:, None], "w": w_world[:, None],
            "x": np.zeros((n, 1, 3)), "v": np.zeros((n, 1, 3))}


def test_case_reads_an_exact_observation_as_exact():
    p = CASE.variant_params("far")
    obs = _observation(p)
    observed, reference = CASE.observables(p, obs), CASE.reference(p, obs["t"])
    bound = _adaptive_bound(p)
    assert np.max(CASE.error(p, observed, reference)) < bound
    metrics = CASE.extra_metrics(p, obs, observed, reference)
    # |L| is conserved by the solve to its rtol per unit time: W t rtol, factor 10 as above
    assert metrics["momentum_drift"] < bound / CASE.motion_scale(p)
    assert "orientation_drift" not in metrics
    energy = CASE.energy(p, obs)
    assert np.max(np.abs(energy - energy[0])) < bound * CASE.energy_scale(p)


def test_case_catches_an_engine_that_reports_body_frame_angular_velocity():
    p = CASE.variant_params("far")
    obs = _observation(p)
    obs["w"] = CASE.body_omega(obs)[:, None]  # the body-frame w, mislabelled as world
    observed, reference = CASE.observables(p, obs), CASE.reference(p, obs["t"])
    assert np.max(CASE.error(p, observed, reference)) > 0.1 * CASE.motion_scale(p)
    assert CASE.extra_metrics(p, obs, observed, reference)["momentum_drift"] > 0.1


def test_orientation_drift_is_the_largest_reported_defect():
    p = CASE.variant_params("far")
    obs = _observation(p, n=5)
    obs["orientation_defect"] = np.array([[0.0], [1e-9], [-3e-9], [2e-9], [0.0]])
    observed = CASE.observables(p, obs)
    metrics = CASE.extra_metrics(p, obs, observed, CASE.reference(p, obs["t"]))
    assert metrics["orientation_drift"] == 3e-9


def test_world_momentum_is_rotated_body_momentum():
    p = CASE.variant_params("near_separatrix")
    body = moments(p) * initial_body_omega(p)
    np.testing.assert_allclose(np.linalg.norm(world_momentum(p)), np.linalg.norm(body))
    np.testing.assert_allclose(world_momentum(p), quat_to_matrix(initial_orientation()) @ body)


@pytest.mark.parametrize("override,name", [({"I1": 2.5}, "I1"), ({"I3": 1.5}, "I3")])
def test_moments_out_of_order_are_rejected_naming_them(override, name):
    with pytest.raises(ValueError, match=f"I1 < I2 < I3.*{name}"):
        CASE.scene(CASE.validate(override))


def test_k2_outside_the_open_unit_interval_is_rejected():
    with pytest.raises(ValueError, match="k2"):
        CASE.validate({"k2": 1.0})


@pytest.mark.parametrize("variant", VARIANTS)
def test_tolerance_is_below_the_motion_for_rk4_at_the_reference_dt(variant):
    """The derived bound promises accuracy at the reference dt for a fourth-order method, and
    is capped (at or above the motion) for first-order ones: their energy error moves the flip."""
    p = CASE.variant_params(variant)
    tol, reason = CASE.tolerance(p, "rk4", 4, CASE.reference_dt(p))
    assert tol < 0.1 * CASE.motion_scale(p) and "flip-timing gain" in reason
    assert CASE.tolerance(p, "symplectic_euler", 1, CASE.reference_dt(p))[0] > tol


@pytest.mark.parametrize("defect", ["heun_as_rk4", "rk3_as_rk4"])
def test_an_rk4_that_is_heun_or_kutta_rk3_exceeds_the_rk4_bound_at_every_dt(defect):
    """The bound is rk4's own (|w0| n |phi_rk4(max|w| h)|, safety 2): an order-2 or order-3
    method at the same dt errs far above it (measured: Heun 1e-3..7e-5, RK3 3e-5..5e-7 against
    bounds 1.3e-7..4e-10)."""
    p = CASE.variant_params("far")
    assert not defect_uncaught(CASE, p, defect, "rk4", 4, CASE.dts(p)), defect


def test_velocity_damping_of_one_in_ten_thousand_a_step_exceeds_the_bound():
    p = CASE.variant_params("far")
    assert not defect_uncaught(CASE, p, "velocity_damping", "rk4", 4, [min(CASE.dts(p))])


def test_refsim_rows_are_within_their_bound_at_the_coarsest_dt():
    p = CASE.variant_params("far")
    dt = max(CASE.dts(p))
    for integrator, order in (("rk4", 4), ("midpoint", 2), ("implicit_midpoint", 2),
                              ("symplectic_euler", 1)):
        err = defect_error(CASE, p, "control", integrator, dt)
        tol = CASE.tolerance(p, integrator, order, dt, "quat_exp")[0]
        # within the bound, and not more than the safety factor x 4 above the error
        assert err <= tol < 10 * err, (integrator, err, tol)


def test_a_velocity_verlet_that_is_explicit_euler_exceeds_the_verlet_bound_at_every_dt():
    """refsim's rigid group offers no velocity Verlet; its explicit Euler rows stand for an
    engine whose "velocity_verlet" is explicit Euler: every one errs above Verlet's bound."""
    p = CASE.variant_params('far')
    assert not defect_uncaught(CASE, p, "control", "explicit_euler", 2, CASE.dts(p),
                               named="velocity_verlet")
