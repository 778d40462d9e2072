"""The configuration-update hook: every stepper moves x through `system.shift` when the system
defines one (rotations on the unit quaternions), and through plain addition otherwise."""
import operator

import numpy as np
import pytest

from refsim.integrators import INTEGRATORS, configuration_update, get_integrator
from refsim.models.system import LinearSystem

H, STEPS = 0.1, 10_000
OMEGA = np.array([0.6, -0.8, 1.6])  # rad/s, |omega| = 1.9
Q0 = np.array([np.cos(0.3), np.sin(0.3) * 0.6, 0.0, np.sin(0.3) * 0.8])  # a unit quaternion
HOOKED = ("rk4", "midpoint", "symplectic_euler")


def quat_mul(p, q):
    """Hamilton product of quaternions (w, x, y, z), shape (..., 4)."""
    pw, px, py, pz = np.moveaxis(p, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q, -1, 0)
    return np.stack([pw * qw - px * qx - py * qy - pz * qz,
                     pw * qx + px * qw + py * qz - pz * qy,
                     pw * qy - px * qz + py * qw + pz * qx,
                     pw * qz + px * qy - py * qx + pz * qw], axis=-1)


def quat_exp(rotation):
    """The unit quaternion of a rotation vector (..., 3): (cos(a/2), sin(a/2) r / a), a = |r|."""
    angle = np.linalg.norm(rotation, axis=-1, keepdims=True)
    return np.concatenate([np.cos(0.5 * angle),
                           0.5 * np.sinc(angle / (2 * np.pi)) * rotation], axis=-1)


class SpinOnQuaternions:
    """A rigid rotation: x the body-to-world unit quaternion (4,), v the body angular velocity
    (3,), a = `alpha` a constant body angular acceleration. shift is the exponential map
    q (+) dtheta = q exp(dtheta / 2)."""

    linear, velocity_dependent = True, False

    def __init__(self, alpha=(0.0, 0.0, 0.0)):
        self.alpha = np.asarray(alpha, float)

    def accel(self, t, q, w):
        return self.alpha + 0.0 * w

    def jacobians(self, t, q, w):
        return np.zeros((3, 3)), np.zeros((3, 3))

    def shift(self, q, rotation):
        return quat_mul(q, quat_exp(rotation))


class SpinInR4:
    """The same constant-omega rotation with the quaternion as a point of R^4 and plain
    addition: x = q, v = q' = q (0, omega) / 2, a = q'' = q' (0, omega) / 2."""

    linear, velocity_dependent = True, True

    def accel(self, t, q, qdot):
        return 0.5 * quat_mul(qdot, np.concatenate([[0.0], OMEGA]))

    def jacobians(self, t, q, qdot):
        right = np.array([quat_mul(e, np.concatenate([[0.0], OMEGA])) for e in np.eye(4)]).T
        return np.zeros((4, 4)), 0.5 * right


def run(stepper, system, x0, v0, h=H, steps=STEPS):
    """Every step's configuration, (steps, ...)."""
    state, xs = stepper.start(system, 0.0, x0, v0, h), []
    for k in range(steps):
        state = stepper.step(system, k * h, state, h)
        xs.append(stepper.output(system, (k + 1) * h, state, h)[0])
    return np.array(xs)


@pytest.mark.parametrize("name", HOOKED)
def test_exponential_map_shift_keeps_unit_quaternion_to_round_off(name):
    qs = run(get_integrator(name), SpinOnQuaternions(), Q0, OMEGA)
    assert np.max(np.abs(np.linalg.norm(qs, axis=-1) - 1.0)) < 1e-12


@pytest.mark.parametrize("name", HOOKED)
def test_plain_addition_of_the_same_rotation_drifts_off_the_unit_sphere(name):
    qdot0 = 0.5 * quat_mul(Q0, np.concatenate([[0.0], OMEGA]))
    qs = run(get_integrator(name), SpinInR4(), Q0, qdot0)
    drift = np.max(np.abs(np.linalg.norm(qs, axis=-1) - 1.0))
    assert drift > 1e-6 or not np.isfinite(drift)


def closed_form_spin(t, omega0, alpha):
    """q(t) for omega(t) = omega0 + alpha t about one fixed axis (the increments commute)."""
    return quat_mul(Q0, quat_exp(np.outer(t, omega0) + np.outer(0.5 * t * t, alpha)))


AXIS = OMEGA / np.linalg.norm(OMEGA)


@pytest.mark.parametrize("name", ["rk4", "midpoint"])
def test_rk_through_the_hook_is_exact_for_constant_angular_acceleration(name):
    """theta'' = alpha about a fixed axis: theta is quadratic in t, which RK4 and the midpoint
    rule integrate exactly, stage times and stage increments included."""
    alpha = -0.3 * AXIS
    qs = run(get_integrator(name), SpinOnQuaternions(alpha), Q0, OMEGA, steps=200)
    exact = closed_form_spin(H * np.arange(1, 201), OMEGA, alpha)
    np.testing.assert_allclose(qs, exact, rtol=0, atol=1e-12)


def test_symplectic_euler_through_the_hook_matches_its_discrete_solution():
    """Kick then drift: theta_n = n h omega0 + h^2 alpha n (n + 1) / 2, exactly."""
    alpha, n = -0.3 * AXIS, np.arange(1, 201)
    qs = run(get_integrator("symplectic_euler"), SpinOnQuaternions(alpha), Q0, OMEGA, steps=200)
    angle = np.outer(n * H, OMEGA) + np.outer(H * H * n * (n + 1) / 2, alpha)
    np.testing.assert_allclose(qs, quat_mul(Q0, quat_exp(angle)), rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", INTEGRATORS)
def test_every_stepper_runs_through_the_hook_on_the_unit_quaternions(name):
    qs = run(get_integrator(name), SpinOnQuaternions(-0.3 * AXIS), Q0, OMEGA, steps=100)
    assert np.max(np.abs(np.linalg.norm(qs, axis=-1) - 1.0)) < 1e-13
    exact = closed_form_spin(H * np.arange(1, 101), OMEGA, -0.3 * AXIS)
    assert np.max(np.abs(qs - exact)) < 0.1  # first-order methods included: near the path


class DampedOscillator(LinearSystem):
    def __init__(self):
        super().__init__([[4.0, 1.0], [1.0, 3.0]], [[0.2, 0.0], [0.0, 0.1]])


class DampedOscillatorIdentityShift(DampedOscillator):
    def shift(self, x, dx):
        return x + dx


# every configuration update is one increment x + dx: the hook changes nothing, bit for bit
SINGLE_INCREMENT = ("explicit_euler", "midpoint", "symplectic_euler", "symplectic_euler_dk",
                    "velocity_verlet", "stormer_verlet", "leapfrog", "implicit_euler",
                    "baraff_witkin")


def _final_state(name, system):
    return run(get_integrator(name), system, np.array([1.0, -0.5]), np.array([0.0, 0.3]),
               h=0.05, steps=200)[-1]


@pytest.mark.parametrize("name", SINGLE_INCREMENT)
def test_identity_shift_gives_bit_identical_states(name):
    # same operations: x + dx through the hook or operator.add, nothing else differs
    assert np.array_equal(_final_state(name, DampedOscillator()),
                          _final_state(name, DampedOscillatorIdentityShift()))


@pytest.mark.parametrize("name", [n for n in INTEGRATORS if n not in SINGLE_INCREMENT])
def test_identity_shift_equals_plain_addition_to_round_off_for_multi_term_sums(name):
    """RK weights with several terms (Heun, Ralston, RK4, Dormand-Prince): under a shift the
    increment h sum b_i V_i is summed before it meets x (the RKMK form), under plain addition
    each term joins x in turn, so the two differ in the last bits only."""
    plain = _final_state(name, DampedOscillator())
    hooked = _final_state(name, DampedOscillatorIdentityShift())
    np.testing.assert_allclose(hooked, plain, rtol=1e-14, atol=1e-15)


def test_a_system_without_shift_is_updated_by_plain_addition():
    assert configuration_update(DampedOscillator()) is operator.add
    system = DampedOscillatorIdentityShift()
    assert configuration_update(system) == system.shift


@pytest.mark.parametrize("name", ["explicit_euler", "midpoint", "heun", "rk4", "dopri5"])
def test_explicit_rk_takes_one_step_size_per_batch_member(name):
    """No per-h coefficient cache: h of shape (batch, 1) steps each member by its own h, bit
    for bit as a scalar-h run of that member."""
    system, hs = LinearSystem([[100.0]]), np.array([0.01, 0.02, 0.05])
    stepper = get_integrator(name)
    batch = run(stepper, system, np.ones((3, 1)), np.zeros((3, 1)), h=hs[:, None], steps=20)
    for i, h in enumerate(hs):
        single = run(stepper, system, np.ones(1), np.zeros(1), h=float(h), steps=20)
        # same operations: elementwise RK combinations; a 1x1 system's products are one term
        assert np.array_equal(batch[:, i], single)
