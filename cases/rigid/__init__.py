"""Rigid-body cases: free rigid bodies with an inertia tensor and an orientation (one scenario
per module), and the quaternion algebra their references and observables share.

Quaternions are (w, x, y, z), scalar first, rotating body vectors into the world frame (the
`RigidBodies` part's convention); angular velocities are in the world frame unless a name says
`body`. `RigidCase` holds what every rigid case reads from an engine's observation (body
angular velocity, orientation drift); it lives here so that its source is part of every rigid
case's `source_hash`.
"""
from __future__ import annotations

import numpy as np

from refsim.case import Case


def quat_multiply(a, b) -> np.ndarray:
    """Hamilton product a (x) b of (..., 4) quaternions."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    aw, av = a[..., :1], a[..., 1:]
    bw, bv = b[..., :1], b[..., 1:]
    scalar = aw * bw - np.sum(av * bv, axis=-1, keepdims=True)
    vector = aw * bv + bw * av + np.cross(av, bv)
    return np.concatenate([scalar, vector], axis=-1)


def quat_conjugate(q) -> np.ndarray:
    q = np.asarray(q, float)
    return np.concatenate([q[..., :1], -q[..., 1:]], axis=-1)


def rotation_quaternion(rotation_vector) -> np.ndarray:
    """Unit quaternion of the rotation by angle |a| about a/|a|, for (..., 3) rotation vectors
    a: (cos(|a|/2), sin(|a|/2) a/|a|), i.e. exp of the pure quaternion a/2 (identity at a = 0)."""
    a = np.asarray(rotation_vector, float)
    half = 0.5 * np.linalg.norm(a, axis=-1, keepdims=True)
    sinc = np.where(half > 0, np.sin(half) / np.where(half > 0, half, 1.0), 1.0)
    return np.concatenate([np.cos(half), 0.5 * sinc * a], axis=-1)


def quat_to_matrix(q) -> np.ndarray:
    """(..., 3, 3) rotation matrices of (..., 4) quaternions (normalised first). Written entry
    by entry into one array: the job's divergence check calls it once per observation, where
    nested np.stack calls cost a quarter of a one-body run."""
    q = np.asarray(q, float)
    w, x, y, z = np.moveaxis(q / np.linalg.norm(q, axis=-1, keepdims=True), -1, 0)
    out = np.empty(q.shape[:-1] + (3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 0, 2] = (1 - 2 * (y * y + z * z),
                                                      2 * (x * y - w * z), 2 * (x * z + w * y))
    out[..., 1, 0], out[..., 1, 1], out[..., 1, 2] = (2 * (x * y + w * z),
                                                      1 - 2 * (x * x + z * z), 2 * (y * z - w * x))
    out[..., 2, 0], out[..., 2, 1], out[..., 2, 2] = (2 * (x * z - w * y), 2 * (y * z + w * x),
                                                      1 - 2 * (x * x + y * y))
    return out


def rotation_angle_between(q_a, q_b) -> np.ndarray:
    """Angle (rad, in [0, pi]) of the rotation taking orientation q_b to q_a: the angle of
    q_a (x) conj(q_b), sign-blind (q and -q are one rotation) and scale-blind (atan2 of the
    vector and scalar parts, so a quaternion off the unit sphere still gives its rotation)."""
    rel = quat_multiply(q_a, quat_conjugate(q_b))
    return 2.0 * np.arctan2(np.linalg.norm(rel[..., 1:], axis=-1), np.abs(rel[..., 0]))


def body_angular_velocity(q, w_world) -> np.ndarray:
    """R(q)^T w: the world angular velocity in the body frame, (..., 3)."""
    return np.einsum("...ji,...j->...i", quat_to_matrix(q), np.asarray(w_world, float))


class RigidCase(Case):
    """A free-body case: one body, read from observations of shape (T, 1, ...)."""

    @staticmethod
    def first_body(obs, name) -> np.ndarray:
        return np.asarray(obs[name], float)[:, 0]

    def body_omega(self, obs) -> np.ndarray:
        """(T, 3) body-frame angular velocity R^T w of the first body."""
        return body_angular_velocity(self.first_body(obs, "q"), self.first_body(obs, "w"))

    def orientation_metrics(self, obs) -> dict:
        """orientation_drift = max |orientation_defect| (det R - 1 or |q|^2 - 1, the engine's
        own measure before any renormalisation), where the engine reports it."""
        if "orientation_defect" not in obs:
            return {}
        defect = np.asarray(obs["orientation_defect"], float)
        return {"orientation_drift": float(np.max(np.abs(defect)))}
