"""Newton-Euler kernels: quaternion/matrix helpers, world inertia, accelerations, energy,
angular momentum, batching, and the inverse differentials the RKMK stages use."""
import numpy as np
import pytest

from refsim.models.rigid_body import (
    RigidBodySystem,
    cross,
    matrix_to_quaternion,
    quaternion_multiply,
    quaternion_to_matrix,
    skew,
    world_inertia,
)
from refsim.models.rigid_orientation import FORMULATIONS, get_formulation

EPS = np.finfo(float).eps
RNG = np.random.default_rng(13)


def unit_quaternions(n):
    q = RNG.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def test_helpers_agree_with_numpy():
    a, b = RNG.normal(size=(5, 3)), RNG.normal(size=(5, 3))
    assert np.allclose(cross(a, b), np.cross(a, b), rtol=0, atol=8 * EPS)
    assert np.allclose(skew(a) @ b[..., None], np.cross(a, b)[..., None], rtol=0, atol=8 * EPS)


def test_quaternion_matrix_round_trip_including_half_turns():
    q = unit_quaternions(50)
    q[:4] = [[0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1], [1e-9, 0.6, 0.8, 0]]  # 180 degrees
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    r = quaternion_to_matrix(q)
    assert np.max(np.abs(np.swapaxes(r, 1, 2) @ r - np.eye(3))) <= 8 * EPS
    back = matrix_to_quaternion(r)
    same = np.minimum(np.abs(back - q).max(axis=1), np.abs(back + q).max(axis=1))
    assert np.max(same) <= 16 * EPS  # q and -q are one rotation
    assert np.all(back[:, 0] >= 0)


def test_quaternion_product_composes_rotations():
    p, q = unit_quaternions(6), unit_quaternions(6)
    assert np.allclose(quaternion_to_matrix(quaternion_multiply(p, q)),
                       quaternion_to_matrix(p) @ quaternion_to_matrix(q), rtol=0,
                       atol=16 * EPS)


def system_of(formulation, n=4):
    inertia = np.array([np.diag(d) for d in RNG.uniform(1, 3, size=(n, 3))])
    mix = quaternion_to_matrix(unit_quaternions(n))  # full (non-diagonal) tensors
    inertia = mix @ inertia @ np.swapaxes(mix, 1, 2)
    inertia = 0.5 * (inertia + np.swapaxes(inertia, 1, 2))
    return RigidBodySystem(RNG.uniform(1, 2, n), inertia, (0.0, 0.0, -9.81),
                           get_formulation(formulation))


@pytest.mark.parametrize("formulation", list(FORMULATIONS))
def test_accel_solves_the_world_frame_newton_euler_equations(formulation):
    system = system_of(formulation)
    x = system.configuration(RNG.normal(size=(4, 3)), unit_quaternions(4))
    v = RNG.normal(size=(4, 6))
    a = system.accel(0.0, x, v)
    inertia_w = world_inertia(system.rotation(x), system.inertia)
    w, w_dot = v[:, 3:], a[:, 3:]
    residual = (inertia_w @ w_dot[..., None])[..., 0] + np.cross(w, (inertia_w @ w[..., None])
                                                                 [..., 0])
    assert np.max(np.abs(residual)) <= 1e3 * EPS  # O(1) entries, a few dozen roundings
    # exact: the translational part is gravity broadcast, no arithmetic
    assert np.array_equal(a[:, :3], np.broadcast_to(system.gravity, (4, 3)))


def test_energy_and_momentum_follow_their_definitions():
    system = system_of("quat_exp", n=2)
    x = system.configuration(RNG.normal(size=(2, 3)), unit_quaternions(2))
    v = RNG.normal(size=(2, 6))
    inertia_w = world_inertia(system.rotation(x), system.inertia)
    momentum = np.einsum("nij,nj->ni", inertia_w, v[:, 3:])
    assert np.allclose(system.angular_momentum(x, v), momentum, rtol=1e-14, atol=0)
    energy = (0.5 * system.mass * np.sum(v[:, :3] ** 2, axis=1)
              + 0.5 * np.sum(v[:, 3:] * momentum, axis=1)
              - system.mass * (x[:, :3] @ system.gravity))
    assert np.allclose(system.energy(x, v), energy, rtol=1e-14, atol=1e-14)


@pytest.mark.parametrize("formulation", list(FORMULATIONS))
def test_a_batch_axis_steps_like_separate_runs(formulation):
    system = system_of(formulation, n=3)
    x = system.configuration(RNG.normal(size=(2, 3, 3)), unit_quaternions(6).reshape(2, 3, 4))
    v = RNG.normal(size=(2, 3, 6))
    dx = 0.01 * RNG.normal(size=(2, 3, 6))
    for member in range(2):
        assert np.allclose(system.accel(0.0, x, v)[member],
                           system.accel(0.0, x[member], v[member]), rtol=1e-15, atol=1e-15)
        assert np.allclose(system.shift(x, dx)[member], system.shift(x[member], dx[member]),
                           rtol=1e-15, atol=1e-15)


@pytest.mark.parametrize("formulation", ["quat_exp", "quat_normalised", "matrix_polar"])
def test_dinv_inverts_the_differential_of_the_map(formulation):
    """d/de map(phi + e dinv(phi, a)) map(phi)^-1 = [a]_x (the right-trivialised derivative of
    the world-frame update); central differences with e = 1e-6 are accurate to ~e^2 |phi''|
    plus eps/e round-off, about 1e-10: 1e-8 leaves a margin of 100."""
    form = get_formulation(formulation)
    o = form.from_quaternion(unit_quaternions(1))
    phi, a = np.array([[0.4, -0.3, 0.5]]), np.array([[0.2, 0.7, -0.1]])
    k, e = form.dinv(phi, a), 1e-6

    def rotation(p):
        return form.matrix(form.shift(o, p))[0]

    derivative = (rotation(phi + e * k) - rotation(phi - e * k)) / (2 * e)
    assert np.max(np.abs(derivative @ rotation(phi).T - skew(a[0]))) <= 1e-8
    assert np.allclose(form.dinv(np.zeros((1, 3)), a), a, rtol=0, atol=EPS)  # identity at 0


def test_matrix_printed_offers_no_stage_correction():
    assert not hasattr(system_of("matrix_printed"), "dexpinv")
    assert hasattr(system_of("quat_exp"), "dexpinv")
