"""Newton-Euler rigid bodies, vectorised over (batch..., n bodies), world frame:

    m v' = F                           (gravity at the centre of mass: F = m g, no torque)
    I_w w' + w x (I_w w) = tau         I_w = R I0 R^T (I0 body frame, about the COM)
    R' = [w]_x R,  q' = 1/2 (0, w) (x) q   (world w acts on the LEFT)
    L = I_w w (world),  E = 1/2 m |v|^2 + 1/2 w . L - m g . x

State for the steppers (`refsim.integrators`): configuration x (..., n, 3 + s) = centre of
mass (3) then the orientation row of the formulation (`rigid_orientation`, s = 4, 5 or 9);
velocity v (..., n, 6) = COM velocity (3) then world angular velocity (3); a configuration
increment dx (..., n, 6) = translation (3) then world rotation vector (3). `shift(x, dx)` moves
x through the formulation; `dexpinv(dx, v)` (formulations on the group) corrects a stage slope
for Runge-Kutta-Munthe-Kaas.

For the orthogonal formulations the angular acceleration is evaluated in the body frame,
w' = R I0^-1 (R^T tau - w_b x I0 w_b), w_b = R^T w, which equals the world-frame equation
exactly when R^T R = I (R^T (w x I_w w) = w_b x I0 w_b). For `matrix_printed` (R not orthogonal)
the world-frame equation is solved as printed, I_w = R I0 R^T with its true inverse.
"""
from __future__ import annotations

import numpy as np


# -- small vector and quaternion helpers (rows, any leading axes) ---------------------------
# Each helper is one product of a row's outer product with a constant matrix (a bilinear map
# written as its coefficients), so that a one-body call costs a few numpy calls instead of
# one per term: on one body the per-call overhead of numpy (about 1 us a call) is the whole
# cost of a step. Every coefficient is 0, 1, -1 (or 2 / |q|^2 applied once after), so each
# output is the same products summed as the written-out formula; BLAS may sum the terms of a
# four-term entry in another order (a last-bit difference from the written-out order).
def _bilinear(pairs, size: int, outputs: int) -> np.ndarray:
    """The (size^2, outputs) coefficients of sum c a_i b_j from {output: ((c, i, j), ...)}."""
    out = np.zeros((size * size, outputs))
    for k, terms in pairs.items():
        for c, i, j in terms:
            out[size * i + j, k] = c
    return out


_CROSS = _bilinear({0: ((1, 1, 2), (-1, 2, 1)), 1: ((1, 2, 0), (-1, 0, 2)),
                    2: ((1, 0, 1), (-1, 1, 0))}, 3, 3)
# Hamilton product p (x) q of (w, x, y, z) rows
_HAMILTON = _bilinear({
    0: ((1, 0, 0), (-1, 1, 1), (-1, 2, 2), (-1, 3, 3)),
    1: ((1, 0, 1), (1, 1, 0), (1, 2, 3), (-1, 3, 2)),
    2: ((1, 0, 2), (-1, 1, 3), (1, 2, 0), (1, 3, 1)),
    3: ((1, 0, 3), (1, 1, 2), (-1, 2, 1), (1, 3, 0))}, 4, 4)
# R - I of a unit quaternion over 2 (rows of R flattened), then |q|^2 in the last column:
# R = I + 2 / |q|^2 * (these nine), the rotation of q / |q| for any q != 0
_ROTATION = _bilinear({
    0: ((-1, 2, 2), (-1, 3, 3)), 1: ((1, 1, 2), (-1, 0, 3)), 2: ((1, 1, 3), (1, 0, 2)),
    3: ((1, 1, 2), (1, 0, 3)), 4: ((-1, 1, 1), (-1, 3, 3)), 5: ((1, 2, 3), (-1, 0, 1)),
    6: ((1, 1, 3), (-1, 0, 2)), 7: ((1, 2, 3), (1, 0, 1)), 8: ((-1, 1, 1), (-1, 2, 2)),
    9: ((1, 0, 0), (1, 1, 1), (1, 2, 2), (1, 3, 3))}, 4, 10)
_IDENTITY = np.eye(3).ravel()
# [a]_x flattened: the matrix of b -> a x b, linear in a (3, 9)
_SKEW = np.zeros((3, 9))
for _k, (_i, _j) in enumerate(((2, 1), (0, 2), (1, 0))):  # [a]_x[i, j] = a_k, [j, i] = -a_k
    _SKEW[_k, 3 * _i + _j], _SKEW[_k, 3 * _j + _i] = 1.0, -1.0


def _outer(a, b):
    """a_i b_j at i * len + j over the last axis (broadcast over the others)."""
    prod = a[..., :, None] * b[..., None, :]
    return prod.reshape(prod.shape[:-2] + (-1,))


def cross(a, b):
    """a x b over the last axis (broadcast over the others)."""
    return _outer(a, b) @ _CROSS


def skew(a):
    """[a]_x, (..., 3, 3): [a]_x b = a x b."""
    return (a @ _SKEW).reshape(a.shape[:-1] + (3, 3))


def matvec(m, v):
    """m @ v for (..., 3, 3) and (..., 3)."""
    return (m @ v[..., None])[..., 0]


def dot(a, b):
    """a . b over the last axis, kept as a length-1 axis (..., 1)."""
    return (a[..., None, :] @ b[..., :, None])[..., 0]


def quaternion_multiply(p, q):
    """Hamilton product p (x) q of (w, x, y, z) rows."""
    return _outer(p, q) @ _HAMILTON


def quaternion_to_matrix(q):
    """The rotation of q / |q| (homogeneous form divided by |q|^2: a rotation for any q != 0)."""
    terms = _outer(q, q) @ _ROTATION
    rows = (2.0 / terms[..., 9:]) * terms[..., :9] + _IDENTITY
    return rows.reshape(q.shape[:-1] + (3, 3))


def matrix_to_quaternion(r):
    """Unit quaternion (w >= 0) of each rotation matrix (..., 3, 3): Shepperd's method, the
    largest of 4 w^2, 4 x^2, 4 y^2, 4 z^2 picks the well-conditioned formula."""
    r = np.asarray(r, float)
    trace = r[..., 0, 0] + r[..., 1, 1] + r[..., 2, 2]
    pick = np.argmax(_shepperd_keys(r, trace), axis=-1)
    d_zy, d_xz, d_yx = (r[..., 2, 1] - r[..., 1, 2], r[..., 0, 2] - r[..., 2, 0],
                        r[..., 1, 0] - r[..., 0, 1])
    s_xy, s_xz, s_yz = (r[..., 0, 1] + r[..., 1, 0], r[..., 0, 2] + r[..., 2, 0],
                        r[..., 1, 2] + r[..., 2, 1])
    one = np.ones_like(trace)
    candidates = np.stack([
        np.stack([1 + trace, d_zy, d_xz, d_yx], -1),
        np.stack([d_zy, 1 + 2 * r[..., 0, 0] - trace, s_xy, s_xz], -1),
        np.stack([d_xz, s_xy, 1 + 2 * r[..., 1, 1] - trace, s_yz], -1),
        np.stack([d_yx, s_xz, s_yz, 1 + 2 * r[..., 2, 2] - trace], -1)], axis=-2)
    q = np.take_along_axis(candidates, pick[..., None, None], axis=-2)[..., 0, :]
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return q * np.where(q[..., :1] < 0, -one[..., None], one[..., None])


def _shepperd_keys(r, trace):
    """4 w^2 - 1, 4 x^2 - 1, ... up to a common offset: trace and 2 R_ii - trace."""
    return np.stack([trace, 2 * r[..., 0, 0] - trace, 2 * r[..., 1, 1] - trace,
                     2 * r[..., 2, 2] - trace], axis=-1)


# -- the system -----------------------------------------------------------------------------
class RigidBodySystem:
    """n free rigid bodies under uniform gravity, one orientation `formulation`
    (`rigid_orientation.Formulation`). `stage_correction=False` withholds the `dexpinv` hook
    (RK stages then use the plain retraction, the "RKMK-lite" of earlier versions)."""

    velocity_dependent = True  # the gyroscopic term w x I_w w
    linear = False

    def __init__(self, mass, inertia, gravity, formulation, stage_correction=True):
        self.mass = np.asarray(mass, float)
        self.inertia = np.asarray(inertia, float)
        self.inertia_inv = np.linalg.inv(self.inertia)
        self.gravity = np.asarray(gravity, float)
        self.formulation = formulation
        self.n = len(self.mass)
        if formulation.dinv is not None and stage_correction:
            self.dexpinv = self._dexpinv

    # state layout
    def configuration(self, position, quaternion):
        """x (..., n, 3 + s) from positions (..., n, 3) and unit quaternions (..., n, 4)."""
        o = self.formulation.from_quaternion(quaternion)
        return np.concatenate([np.asarray(position, float), o], axis=-1)

    @staticmethod
    def velocity(velocity, angular_velocity):
        return np.concatenate([np.asarray(velocity, float),
                               np.asarray(angular_velocity, float)], axis=-1)

    def rotation(self, x):
        return self.formulation.matrix(x[..., 3:])

    # the stepper hooks
    def shift(self, x, dx):
        return np.concatenate([x[..., :3] + dx[..., :3],
                               self.formulation.shift(x[..., 3:], dx[..., 3:])], axis=-1)

    def _dexpinv(self, dx, v):
        return np.concatenate([v[..., :3], self.formulation.dinv(dx[..., 3:], v[..., 3:])],
                              axis=-1)

    def angular_acceleration(self, r, w, torque=None, body_torque=None):
        """w' from I_w w' + w x (I_w w) = tau (see the module docstring); tau given in the
        world frame (`torque`) or, for the orthogonal formulations, in the body frame
        (`body_torque`, R^T tau)."""
        if self.formulation.orthogonal:
            w_body = (w[..., None, :] @ r)[..., 0, :]  # R^T w
            rhs = -cross(w_body, matvec(self.inertia, w_body))
            if torque is not None:
                rhs = rhs + (torque[..., None, :] @ r)[..., 0, :]
            if body_torque is not None:
                rhs = rhs + body_torque
            return matvec(r, matvec(self.inertia_inv, rhs))
        if body_torque is not None:
            raise ValueError("body_torque needs an orthogonal formulation (R^T R = I)")
        inertia_w = world_inertia(r, self.inertia)
        rhs = -cross(w, matvec(inertia_w, w))
        if torque is not None:
            rhs = rhs + torque
        return np.linalg.solve(inertia_w, rhs[..., None])[..., 0]

    def accel(self, t, x, v):
        r = self.rotation(x)
        w_dot = self.angular_acceleration(r, v[..., 3:])
        return np.concatenate([np.broadcast_to(self.gravity, w_dot.shape), w_dot], axis=-1)

    # observables
    def angular_momentum(self, x, v):
        """World L = I_w w, (..., n, 3)."""
        return matvec(world_inertia(self.rotation(x), self.inertia), v[..., 3:])

    def energy(self, x, v):
        """Per body: 1/2 m |v|^2 + 1/2 w . L - m g . x, (..., n)."""
        lin, w = v[..., :3], v[..., 3:]
        rot = np.sum(w * self.angular_momentum(x, v), axis=-1)
        return (0.5 * self.mass * np.sum(lin * lin, axis=-1) + 0.5 * rot
                - self.mass * (x[..., :3] @ self.gravity))

    def defect(self, x):
        return self.formulation.defect(x[..., 3:])

    def quaternion(self, x):
        return self.formulation.quaternion(x[..., 3:])


def world_inertia(r, inertia):
    """I_w = R I0 R^T, (..., n, 3, 3)."""
    return r @ inertia @ np.swapaxes(r, -1, -2)
