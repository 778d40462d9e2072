"""Rigid bodies each turning about a fixed point (a ball joint to the world), vectorised over
(batch..., n bodies), world frame:

    I_p w' + w x (I_p w) = tau,   I_p = R I_pivot R^T,   tau = (R c) x m g
    I_pivot = I0 + m (|c|^2 1 - c c^T)   (parallel axis; I0 about the centre of mass, body frame)
    x = anchor + R c,   v = w x (R c)    (c: the centre of mass from the pivot, body frame)
    L = I_p w (world, about the pivot),  E = 1/2 w . L - m g . x

c = -body_point of the `RigidPivots` part (body_point: the pivot from the centre of mass).
State for the steppers (`refsim.integrators`): configuration x (..., n, s) = the orientation row
of the formulation (`rigid_orientation`, s = 4, 5 or 9) and nothing else (the pivot fixes the
centre of mass's place); velocity v (..., n, 3) = world angular velocity; an increment dx
(..., n, 3) = a world rotation vector. `shift` and `dexpinv` are the formulation's own
(exp / Cayley / polar maps and their inverse differentials), so every formulation and stepper
of the free rigid body runs here unchanged.

The angular acceleration is the free body's (`RigidBodySystem.angular_acceleration`) with the
pivot inertia in place of I0 and the gravity torque about the pivot: body frame for the
orthogonal formulations, the world-frame equation as printed for `matrix_printed`.
"""
from __future__ import annotations

import numpy as np

from .rigid_body import RigidBodySystem, cross, matvec, world_inertia


def pivot_inertia(inertia, mass, com_offset):
    """I_pivot = I0 + m (|c|^2 1 - c c^T), (n, 3, 3): the inertia about the pivot, body frame,
    of bodies with inertia I0 (n, 3, 3) about their centres of mass, masses m (n,) and centres
    of mass at c (n, 3) from the pivot."""
    c = np.asarray(com_offset, float)
    m = np.asarray(mass, float)[:, None, None]
    c2 = np.sum(c * c, axis=-1)[:, None, None]
    return np.asarray(inertia, float) + m * (c2 * np.eye(3) - c[:, :, None] * c[:, None, :])


class PivotedRigidSystem:
    """n rigid bodies, body i turning about its pivot `anchor[i]` (world) with its centre of
    mass at `com_offset[i]` (body frame, from the pivot), under uniform gravity, one
    orientation `formulation` (`rigid_orientation.Formulation`). `stage_correction=False`
    withholds the `dexpinv` hook, as for the free body."""

    velocity_dependent = True  # the gyroscopic term w x I_p w
    linear = False

    def __init__(self, mass, inertia, com_offset, anchor, gravity, formulation,
                 stage_correction=True):
        self.mass = np.asarray(mass, float)
        self.com_offset = np.asarray(com_offset, float)
        self.anchor = np.asarray(anchor, float)
        self.gravity = np.asarray(gravity, float)
        self.formulation = formulation
        self.n = len(self.mass)
        if self.com_offset.shape != (self.n, 3) or self.anchor.shape != (self.n, 3):
            raise ValueError(f"com_offset and anchor must have shape ({self.n}, 3), got "
                             f"{self.com_offset.shape} and {self.anchor.shape}")
        self.inertia_pivot = pivot_inertia(inertia, self.mass, self.com_offset)
        self._turning = RigidBodySystem(self.mass, self.inertia_pivot, self.gravity,
                                        formulation)
        self.weight = self.mass[:, None] * self.gravity  # m g, (n, 3)
        if formulation.dinv is not None and stage_correction:
            self.dexpinv = formulation.dinv

    # state layout
    def configuration(self, quaternion):
        """x (..., n, s) from unit quaternions (..., n, 4)."""
        return self.formulation.from_quaternion(quaternion)

    def rotation(self, x):
        return self.formulation.matrix(x)

    # the stepper hooks
    def shift(self, x, dx):
        return self.formulation.shift(x, dx)

    def com_arm(self, x):
        """R c: the centre of mass from the pivot, world frame, (..., n, 3)."""
        return matvec(self.rotation(x), self.com_offset)

    def accel(self, t, x, v):
        r = self.rotation(x)
        if self.formulation.orthogonal:  # R^T ((R c) x m g) = c x (R^T m g) when R^T R = I
            weight_body = (self.weight[..., None, :] @ r)[..., 0, :]
            return self._turning.angular_acceleration(
                r, v, body_torque=cross(self.com_offset, weight_body))
        torque = cross(matvec(r, self.com_offset), self.weight)
        return self._turning.angular_acceleration(r, v, torque)

    # observables
    def position(self, x):
        """Centres of mass, anchor + R c, (..., n, 3)."""
        return self.anchor + self.com_arm(x)

    def com_velocity(self, x, v):
        """w x (R c), (..., n, 3)."""
        return cross(v, self.com_arm(x))

    def angular_momentum(self, x, v):
        """World L = I_p w about each pivot, (..., n, 3)."""
        return matvec(world_inertia(self.rotation(x), self.inertia_pivot), v)

    def energy(self, x, v):
        """Per body: 1/2 w . L - m g . x, (..., n)."""
        kinetic = 0.5 * np.sum(v * self.angular_momentum(x, v), axis=-1)
        return kinetic - np.sum(self.weight * self.position(x), axis=-1)

    def defect(self, x):
        return self.formulation.defect(x)

    def quaternion(self, x):
        return self.formulation.quaternion(x)
