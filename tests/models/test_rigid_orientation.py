"""Orientation formulations: exact discrete drift oracles, measured orders on a tumbling
asymmetric top, conservation under the implicit midpoint rule, symplectic Euler's energy gain."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from refsim.integrators import get_integrator
from refsim.models.rigid_body import RigidBodySystem, quaternion_multiply, quaternion_to_matrix
from refsim.models.rigid_orientation import FORMULATIONS, get_formulation, quaternion_exp_half

EPS = np.finfo(float).eps
INERTIA = np.diag([1.0, 2.0, 3.0])
Q_TILT = np.array([0.9, 0.1, -0.3, 0.2]) / np.linalg.norm([0.9, 0.1, -0.3, 0.2])


def make(formulation, w_world, stage_correction=True):
    system = RigidBodySystem([1.0], INERTIA[None], (0.0, 0.0, 0.0),
                             get_formulation(formulation), stage_correction)
    x = system.configuration(np.zeros((1, 3)), Q_TILT[None])
    return system, x, system.velocity(np.zeros((1, 3)), np.asarray(w_world)[None])


def run(system, x, v, integrator, h, steps):
    stepper = get_integrator(integrator)
    _, state = stepper.advance(system, 0.0, stepper.start(system, 0.0, x, v, h), h, steps)
    return stepper.output(system, 0.0, state, h)


# -- (1) exact discrete drift at constant spin about a principal axis tilted in the world -----
H, STEPS, SPIN = 0.01, 200, 10.0  # h |w| = 0.1
# Every step is a fixed number of roundings of O(1) numbers, each within eps/2 relative; the
# checks below allow 20 eps of relative error per step (a generous bound on that count),
# accumulated over STEPS steps: a formula off by one power of (1 + h^2|w|^2) (1e-2) or one
# missing h^2 term fails by ten orders of magnitude.
ROUND_OFF = 20 * EPS * STEPS


def spin_run(formulation):
    """Torque-free spin about body axis 3 (a principal axis: w x I_w w = 0, so w is constant
    for every formulation), STEPS symplectic Euler steps."""
    w_world = SPIN * quaternion_to_matrix(Q_TILT) @ np.array([0.0, 0.0, 1.0])
    system, x, v = make(formulation, w_world)
    x1, v1 = run(system, x, v, "symplectic_euler", H, STEPS)
    assert np.max(np.abs(v1 - v)) <= ROUND_OFF * SPIN  # w constant: the oracles hold
    return system, x1, w_world


def test_matrix_printed_det_grows_as_one_plus_h2w2_power_k():
    system, x, _ = spin_run("matrix_printed")
    expected = (1.0 + (H * SPIN) ** 2) ** STEPS
    det = 1.0 + system.formulation.det_defect(x[:, 3:])[0]
    assert abs(det / expected - 1.0) <= ROUND_OFF
    assert expected - 1.0 > 6.0  # the oracle is not trivially 1: det grew sevenfold


def test_quat_normalised_hidden_norm_is_one_plus_h2w2_over_4_power_k():
    system, x, _ = spin_run("quat_normalised")
    expected = (1.0 + (H * SPIN) ** 2 / 4.0) ** STEPS
    assert abs((1.0 + system.defect(x)[0]) / expected - 1.0) <= ROUND_OFF
    assert abs(np.linalg.norm(x[0, 3:7]) - 1.0) <= 4 * EPS  # the stored q shows nothing


def test_quat_exp_is_the_exact_rotation():
    system, x, w_world = spin_run("quat_exp")
    exact = quaternion_multiply(quaternion_exp_half(STEPS * H * w_world), Q_TILT)
    assert np.max(np.abs(x[0, 3:] - exact)) <= ROUND_OFF
    assert abs(system.defect(x)[0]) <= ROUND_OFF


def test_matrix_polar_stays_orthogonal_and_turns_atan_hw_per_step():
    system, x, w_world = spin_run("matrix_polar")
    # each SVD re-orthonormalises afresh: the orthogonality error does not accumulate
    assert system.defect(x)[0] <= 20 * EPS
    # polar(I + h [w]_x) is the rotation by atan(h |w|) about w, exactly
    angle = STEPS * np.arctan(H * SPIN)
    exact = quaternion_to_matrix(quaternion_multiply(
        quaternion_exp_half(angle * w_world / SPIN), Q_TILT))
    assert np.max(np.abs(system.rotation(x)[0] - exact)) <= ROUND_OFF


# -- (2) measured orders on a tumbling asymmetric top ------------------------------------------
W_BODY0, T_END = np.array([0.3, 1.0, 0.2]), 2.0  # near the intermediate axis: it tumbles


@pytest.fixture(scope="module")
def tumbling_reference():
    """Body-frame Euler equations I w_b' = -w_b x I w_b and R' = R [w_b]_x, DOP853 rtol 1e-12:
    its error (~1e-12) is below the smallest error measured here (~1e-10) by 100x."""
    def rhs(t, y):
        wb, r = y[:3], y[3:].reshape(3, 3)
        wx = np.array([[0, -wb[2], wb[1]], [wb[2], 0, -wb[0]], [-wb[1], wb[0], 0]])
        return np.concatenate([np.linalg.solve(INERTIA, -np.cross(wb, INERTIA @ wb)),
                               (r @ wx).ravel()])
    r0 = quaternion_to_matrix(Q_TILT)
    sol = solve_ivp(rhs, (0, T_END), np.concatenate([W_BODY0, r0.ravel()]), method="DOP853",
                    rtol=1e-12, atol=1e-14)
    r_end = sol.y[3:, -1].reshape(3, 3)
    return r_end, r_end @ sol.y[:3, -1]


def tumbling_error(reference, formulation, integrator, h, stage_correction=True):
    system, x, v = make(formulation, quaternion_to_matrix(Q_TILT) @ W_BODY0, stage_correction)
    x1, v1 = run(system, x, v, integrator, h, int(round(T_END / h)))
    r_ref, w_ref = reference
    return max(np.max(np.abs(system.rotation(x1)[0] - r_ref)),
               np.max(np.abs(v1[0, 3:] - w_ref)))


def measured_order(reference, formulation, integrator, hs, stage_correction=True):
    errors = [tumbling_error(reference, formulation, integrator, h, stage_correction)
              for h in hs]
    return np.polyfit(np.log(hs), np.log(errors), 1)[0]


RK_STEPS = (0.04, 0.02, 0.01)  # RK4 errors 2e-8 .. 1e-10, far above the reference's 1e-12
LOW_STEPS = (0.004, 0.002, 0.001)


@pytest.mark.parametrize("formulation", ["quat_exp", "quat_normalised", "matrix_polar"])
@pytest.mark.parametrize("integrator, hs, order", [
    ("symplectic_euler", LOW_STEPS, 1.0), ("rk4", RK_STEPS, 4.0),
    ("implicit_midpoint", RK_STEPS, 2.0)])
def test_orders_on_the_tumbling_top(tumbling_reference, formulation, integrator, hs, order):
    # within 0.2: the asymptotic regime is reached at these h (errors halve cleanly), and 0.2
    # is far from the next integer order a wrong correction would give
    assert measured_order(tumbling_reference, formulation, integrator, hs) == \
        pytest.approx(order, abs=0.2)


@pytest.mark.parametrize("formulation", ["quat_exp", "quat_normalised", "matrix_polar"])
def test_rk4_without_the_dexpinv_correction_is_second_order(tumbling_reference, formulation):
    # the dropped commutator terms are O(h^3) a step (explicit_rk's docstring)
    assert measured_order(tumbling_reference, formulation, "rk4", RK_STEPS,
                          stage_correction=False) == pytest.approx(2.0, abs=0.2)


def test_matrix_printed_is_first_order_under_every_stepper(tumbling_reference):
    # R + [phi]_x R leaves the group at O(h^2) a step: a first-order retraction caps the order
    for integrator in ("rk4", "implicit_midpoint"):
        assert measured_order(tumbling_reference, "matrix_printed", integrator, RK_STEPS) == \
            pytest.approx(1.0, abs=0.2)


# -- (3) conservation under the implicit midpoint rule -----------------------------------------
def drift_history(formulation, integrator, h, t_end, samples=100):
    system, x, v = make(formulation, quaternion_to_matrix(Q_TILT) @ W_BODY0)
    stepper = get_integrator(integrator)
    state = stepper.start(system, 0.0, x, v, h)
    l0, e0 = system.angular_momentum(x, v)[0], system.energy(x, v)[0]
    chunk, out = int(round(t_end / h / samples)), []
    for _ in range(samples):
        _, state = stepper.advance(system, 0.0, state, h, chunk)
        x1, v1 = stepper.output(system, 0.0, state, h)
        out.append((np.linalg.norm(system.angular_momentum(x1, v1)[0] - l0)
                    / np.linalg.norm(l0), (system.energy(x1, v1)[0] - e0) / e0))
    return np.array(out)


def test_implicit_midpoint_conserves_l_and_e_to_order_two_without_drift():
    """The Lie midpoint rule is symmetric, not exactly conservative: |L(t) - L0|/|L0| and
    |E(t) - E0|/E0 stay bounded (no secular drift) and shrink as h^2."""
    coarse = drift_history("quat_exp", "implicit_midpoint", 0.1, 200.0)
    fine = drift_history("quat_exp", "implicit_midpoint", 0.05, 200.0)
    ratio = np.max(np.abs(coarse), axis=0) / np.max(np.abs(fine), axis=0)
    assert np.log2(ratio) == pytest.approx([2.0, 2.0], abs=0.2)
    # bounded: a secular (linear) drift would make the max over [0, 200] four times the max
    # over [0, 50]; an oscillating error leaves it about equal. 1.5 lies between the two.
    quarter = np.max(np.abs(coarse[:25]), axis=0)
    assert np.all(np.max(np.abs(coarse), axis=0) <= 1.5 * quarter)
    assert np.all(np.max(np.abs(coarse), axis=0) < [1e-2, 1e-3])  # measured 5.5e-3, 4.2e-4


# -- (4) symplectic Euler's explicit gyroscopic term gains energy ------------------------------
def test_symplectic_euler_gains_energy_on_the_tumbling_top():
    """h |w| = 0.106: the explicit gyroscopic term pumps energy in (MuJoCo's documentation
    warns of the same); measured +3.9 (E grows to 4.9 E0) over 100 s."""
    history = drift_history("quat_exp", "symplectic_euler", 0.1, 100.0)
    energy = history[:, 1]
    assert energy[-1] > 1.0  # a gain, not a loss, and not a small one
    assert np.all(np.diff(energy[::10]) > 0)  # monotone on a coarse sampling


def test_every_formulation_is_listed_with_a_description():
    assert list(FORMULATIONS) == ["quat_exp", "quat_normalised", "matrix_printed",
                                  "matrix_polar"]
    assert all(f.description for f in FORMULATIONS.values())
    with pytest.raises(ValueError, match="formulation must be one of"):
        get_formulation("euler_angles")
