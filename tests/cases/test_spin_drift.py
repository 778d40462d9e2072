"""Spin drift: the exact orientation, and the exact discrete drift oracles checked against the
steps themselves, computed independently (matrix powers, SVD polar factors, quaternion steps)."""
import numpy as np
import pytest

from refsim_adapters.planted_defects.checks import defect_error, defect_uncaught
from refsim_cases.rigid import (quat_multiply, quat_to_matrix, rotation_angle_between,
                                rotation_quaternion)
from refsim_cases.rigid.spin_drift import (CASE, FORMULATIONS, PRINCIPAL_MOMENTS,
                                           discrete_angle_error, discrete_defect)
from refsim.integrators import get_integrator

EPS = np.finfo(float).eps


def _cross_matrix(w):
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _polar(matrix):
    u, _, vt = np.linalg.svd(matrix)
    return u @ vt


def _matrix_to_rotation_angle(rotation):
    return np.arccos(np.clip(0.5 * (np.trace(rotation) - 1.0), -1.0, 1.0))


@pytest.mark.parametrize("seed", range(5))
def test_one_step_factors_are_one_plus_y_squared_and_one_plus_y_squared_over_four(seed):
    rng = np.random.default_rng(seed)
    w, h = rng.normal(size=3) * 10, rng.uniform(1e-3, 0.1)
    y2 = h * h * w @ w
    # det(I + h[w]x) = 1 + h^2 |w|^2 exactly; numerically to a few eps of the entries' size
    assert np.linalg.det(np.eye(3) + h * _cross_matrix(w)) == pytest.approx(1 + y2, rel=1e-14)
    step = np.r_[1.0, 0.5 * h * w]  # (1, (h/2) w) (x) q: the Euler quaternion step's factor
    assert step @ step == pytest.approx(1 + y2 / 4, rel=1e-15)
    assert discrete_defect("matrix_printed", h, w, 1) == pytest.approx(y2, rel=1e-13)
    assert discrete_defect("quat_normalised", h, w, 1) == pytest.approx(y2 / 4, rel=1e-13)


def _iterate(formulation, h, w, q0, k):
    """k steps at constant w of one formulation: (rotation the step left, orientation
    defect). The normalised quaternion keeps the product of squared norms it removed."""
    r0, q, removed = quat_to_matrix(q0), q0.copy(), 1.0
    step = np.eye(3) + h * _cross_matrix(w)
    if formulation == "matrix_printed":
        matrix = np.linalg.matrix_power(step, k) @ r0
        return _polar(matrix), np.linalg.det(matrix) - 1.0
    if formulation == "matrix_polar":
        matrix = r0
        for _ in range(k):
            matrix = _polar(step @ matrix)
        return matrix, np.linalg.det(matrix) - 1.0
    for _ in range(k):
        if formulation == "quat_exp":
            q = quat_multiply(rotation_quaternion(h * w), q)
        else:
            q = q + 0.5 * h * quat_multiply(np.r_[0.0, w], q)
            removed *= q @ q
            q = q / np.linalg.norm(q)
    return quat_to_matrix(q), removed - 1.0


@pytest.mark.parametrize("formulation", FORMULATIONS)
@pytest.mark.parametrize("y", [0.01, 0.5])
def test_discrete_oracles_match_the_iterated_step_to_round_off(formulation, y):
    rng = np.random.default_rng(3)
    axis = rng.normal(size=3)
    w = axis / np.linalg.norm(axis) * 7.0
    h, k = y / 7.0, 40
    q0 = rotation_quaternion(rng.normal(size=3))
    rotation, defect = _iterate(formulation, h, w, q0, k)
    oracle = discrete_defect(formulation, h, w, k)
    # k steps each rounding the defect's factor by a few eps: 10 k eps relative, and an
    # absolute 10 k eps where the exact defect is 0
    assert abs(defect - oracle) <= 10 * k * EPS * (1.0 + abs(oracle))
    exact = rotation_quaternion(k * h * w)
    expected = quat_multiply(rotation_quaternion(-discrete_angle_error(formulation, h, w, k)
                                                 * w / 7.0), exact)
    error = _matrix_to_rotation_angle(rotation @ quat_to_matrix(quat_multiply(
        expected, q0)).T)
    # arccos near 1 resolves an angle only to sqrt(2 eps) = 2e-8: the test's own reading limit
    assert error <= 10 * k * EPS + np.sqrt(2 * EPS)


def test_exp_map_and_polar_have_no_defect_and_printed_matrix_grows_geometrically():
    np.testing.assert_array_equal(discrete_defect("quat_exp", 0.01, 5.0, [1, 10]), [0, 0])
    np.testing.assert_array_equal(discrete_defect("matrix_polar", 0.01, 5.0, 3), 0.0)
    np.testing.assert_allclose(discrete_defect("matrix_printed", 0.1, 5.0, [1, 2, 3]),
                               1.25 ** np.array([1, 2, 3]) - 1, rtol=1e-14)
    np.testing.assert_allclose(discrete_angle_error("quat_exp", 0.1, 5.0, 100), 0.0)


def test_unknown_formulation_is_rejected_naming_the_choices():
    with pytest.raises(ValueError, match="formulation must be one of"):
        discrete_defect("euler_angles", 0.01, 1.0, 1)


@pytest.mark.parametrize("variant", list(CASE.variants))
def test_exact_orientation_spins_about_the_tilted_body_axis(variant):
    p = CASE.variant_params(variant)
    t = np.linspace(0.0, CASE.t_end(p), 11)
    rotations = quat_to_matrix(CASE.exact_orientation(p, t))
    w = CASE.spin_vector(p)
    # body axis 3 stays along w (tilted by `tilt` from world z), w x I_w w = 0
    np.testing.assert_allclose(rotations[:, :, 2] * p["spin"], np.tile(w, (11, 1)), atol=1e-12
                               * p["spin"])
    assert np.degrees(np.arccos(w[2] / p["spin"])) == pytest.approx(p["tilt"])
    inertia_world = rotations[3] @ np.diag(PRINCIPAL_MOMENTS) @ rotations[3].T
    np.testing.assert_allclose(np.cross(w, inertia_world @ w), 0.0, atol=1e-12 * p["spin"] ** 2)
    # no body axis lies on a world axis at t = 0
    assert np.max(np.abs(rotations[0])) < np.cos(np.radians(10))


def test_exact_orientation_solves_q_dot_is_half_w_times_q():
    p = CASE.variant_params("slow")
    t, h = np.array([1.3]), 1e-5
    derivative = (CASE.exact_orientation(p, t + h) - CASE.exact_orientation(p, t - h)) / (2 * h)
    expected = 0.5 * quat_multiply(np.r_[0.0, CASE.spin_vector(p)], CASE.exact_orientation(p, t))
    # central difference: error |w|^3 h^2 / 24 + eps / h; 1e-10 covers both at |w| = 1
    np.testing.assert_allclose(derivative, expected, atol=1e-10)


def _observation(p, q, t):
    n = len(t)
    return {"t": t, "q": q[:, None], "w": np.tile(CASE.spin_vector(p), (n, 1, 1)),
            "x": np.zeros((n, 1, 3)), "v": np.zeros((n, 1, 3))}


def test_angle_error_reads_exact_orientation_as_zero_and_a_known_offset_as_its_angle():
    p = CASE.variant_params("fast")
    t = np.linspace(0.0, CASE.t_end(p), 21)
    exact = CASE.exact_orientation(p, t)
    observed = CASE.observables(p, _observation(p, -exact, t))  # -q: the same rotation
    assert np.max(observed["angle_error"]) < 1e-7  # atan2 of a round-off vector part
    # same operations: w is spin_vector(p) tiled, minus spin_vector(p): x - x = 0
    assert np.max(observed["w_error"]) == 0.0
    offset = quat_multiply(rotation_quaternion([0.0, 0.02, 0.0]), exact) * 1.5  # off-unit
    observed = CASE.observables(p, _observation(p, offset, t))
    np.testing.assert_allclose(observed["angle_error"], 0.02, rtol=1e-9)
    assert np.max(CASE.error(p, observed, CASE.reference(p, t))) == pytest.approx(0.02)


def test_rotation_angle_between_is_sign_and_scale_blind():
    axis = np.array([0.3, -0.2, 0.9])
    a = rotation_quaternion(axis)
    b = rotation_quaternion(axis * (1.0 + 0.1 / np.linalg.norm(axis)))  # 0.1 rad further
    assert rotation_angle_between(-2.0 * a, b) == pytest.approx(0.1, rel=1e-12)


@pytest.mark.parametrize("variant", list(CASE.variants))
@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_one_stage_oracle_is_the_kick_drift_bound_up_to_round_off(variant, formulation):
    """Semi-implicit Euler's exact angle error (the oracle above, written from the step
    angles) is the bound's exact term: the bound exceeds it by its round-off terms only."""
    p = CASE.variant_params(variant)
    for dt in CASE.dts(p):
        steps = round(CASE.t_end(p) / dt)
        oracle = discrete_angle_error(formulation, dt, p["spin"], steps)
        tol = CASE.tolerance(p, "symplectic_euler", 1, dt, formulation)[0]
        roundoff = steps * EPS * 2.0
        assert oracle <= tol
        if variant == "slow":  # lambda h <= 0.01: no growth, the round-off terms only
            assert tol - oracle < 10 * roundoff, (dt, tol, oracle)


@pytest.mark.parametrize("formulation,integrator", [("quat_normalised", "rk4"),
                                                    ("matrix_polar", "midpoint"),
                                                    ("quat_normalised", "implicit_midpoint"),
                                                    ("quat_exp", "symplectic_euler")])
def test_refsim_errs_its_exact_discrete_angle_within_the_bound(formulation, integrator):
    """At the finest dt of the fast spin the error IS the bound's exact term (RKMK turning in
    the chart, from the tableau), or the kick-drift's grown round-off, within the bound."""
    p = CASE.variant_params("fast")
    dt = min(CASE.dts(p))
    order = get_integrator(integrator).order
    err = defect_error(CASE, p, "control", integrator, dt, formulation)
    tol = CASE.tolerance(p, integrator, order, dt, formulation)[0]
    assert err <= tol < 10 * err, (err, tol)


@pytest.mark.parametrize("defect", ["heun_as_rk4", "rk3_as_rk4"])
def test_an_rk4_that_is_heun_or_kutta_rk3_exceeds_the_rk4_bound(defect):
    """On the exponential map every RKMK method turns exactly at constant w (round-off only,
    below the floor: nothing to catch); in the Cayley chart each tableau turns by its own
    angle: a wrong tableau exceeds rk4's exact error at every dt."""
    p = CASE.variant_params("fast")
    assert not defect_uncaught(CASE, p, defect, "rk4", 4, CASE.dts(p),
                               formulation="quat_normalised"), defect


def test_velocity_damping_exceeds_the_bound_at_the_finest_dt():
    p = CASE.variant_params("fast")
    assert not defect_uncaught(CASE, p, "velocity_damping", "rk4", 4, [min(CASE.dts(p))])


def test_gyroscopic_rate_is_the_linearised_euler_frequency():
    p = CASE.variant_params("fast")
    i1, i2, i3 = PRINCIPAL_MOMENTS
    assert CASE.gyroscopic_rate(p) == pytest.approx(
        p["spin"] * np.sqrt((i3 - i1) * (i3 - i2) / (i1 * i2)), rel=1e-12)


def test_orientation_drift_is_the_largest_reported_defect():
    p = CASE.variant_params("slow")
    t = np.linspace(0.0, 1.0, 3)
    obs = _observation(p, CASE.exact_orientation(p, t), t)
    obs["orientation_defect"] = discrete_defect("matrix_printed", 0.01, p["spin"], [[0], [1], [2]])
    metrics = CASE.extra_metrics(p, obs, CASE.observables(p, obs), CASE.reference(p, t))
    assert metrics["orientation_drift"] == pytest.approx(1.0001 ** 2 - 1, rel=1e-12)
    # same operations: w is spin_vector(p) tiled, minus spin_vector(p): x - x = 0
    assert metrics["w_drift"] == 0.0


def test_a_velocity_verlet_that_is_explicit_euler_exceeds_the_verlet_bound_at_every_dt():
    """refsim's rigid group offers no velocity Verlet; its explicit Euler rows stand for an
    engine whose "velocity_verlet" is explicit Euler: every one errs above Verlet's bound."""
    p = CASE.variant_params('fast')
    assert not defect_uncaught(CASE, p, "control", "explicit_euler", 2, CASE.dts(p),
                               named="velocity_verlet")
