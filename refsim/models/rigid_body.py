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
def cross(a, b):
    """a x b over the last axis (faster than np.cross for many small rows; written into one
    preallocated array: np.stack cost a third of a one-body step)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(_shape(a, b))
    np.subtract(a1 * b2, a2 * b1, out=out[..., 0])
    np.subtract(a2 * b0, a0 * b2, out=out[..., 1])
    np.subtract(a0 * b1, a1 * b0, out=out[..., 2])
    return out


def _shape(a, b) -> tuple:
    """The broadcast shape of a and b (np.broadcast_shapes costs more than the arithmetic of
    a one-body step; equal shapes, the usual case, skip it)."""
    return a.shape if a.shape == b.shape else np.broadcast_shapes(a.shape, b.shape)


def skew(a):
    """[a]_x, (..., 3, 3): [a]_x b = a x b."""
    zero = np.zeros(a.shape[:-1])
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    return np.stack([np.stack([zero, -a2, a1], -1), np.stack([a2, zero, -a0], -1),
                     np.stack([-a1, a0, zero], -1)], axis=-2)


def matvec(m, v):
    """m @ v for (..., 3, 3) and (..., 3)."""
    return (m @ v[..., None])[..., 0]


def quaternion_multiply(p, q):
    """Hamilton product p (x) q of (w, x, y, z) rows."""
    pw, px, py, pz = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    qw, qx, qy, qz = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    out = np.empty(_shape(p, q))
    out[..., 0] = pw * qw - px * qx - py * qy - pz * qz
    out[..., 1] = pw * qx + px * qw + py * qz - pz * qy
    out[..., 2] = pw * qy - px * qz + py * qw + pz * qx
    out[..., 3] = pw * qz + px * qy - py * qx + pz * qw
    return out


def quaternion_to_matrix(q):
    """The rotation of q / |q| (homogeneous form divided by |q|^2: a rotation for any q != 0)."""
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    s = 2.0 / (w * w + x * x + y * y + z * z)
    xx, yy, zz, xy, xz, yz = x * x, y * y, z * z, x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    out = np.empty(q.shape[:-1] + (3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 0, 2] = 1 - s * (yy + zz), s * (xy - wz), s * (xz + wy)
    out[..., 1, 0], out[..., 1, 1], out[..., 1, 2] = s * (xy + wz), 1 - s * (xx + zz), s * (yz - wx)
    out[..., 2, 0], out[..., 2, 1], out[..., 2, 2] = s * (xz - wy), s * (yz + wx), 1 - s * (xx + yy)
    return out


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

    def angular_acceleration(self, r, w, torque=None):
        """w' from I_w w' + w x (I_w w) = tau (see the module docstring)."""
        if self.formulation.orthogonal:
            w_body = matvec(np.swapaxes(r, -1, -2), w)
            rhs = -cross(w_body, matvec(self.inertia, w_body))
            if torque is not None:
                rhs = rhs + matvec(np.swapaxes(r, -1, -2), torque)
            return matvec(r, matvec(self.inertia_inv, rhs))
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
