"""Principal frames and quaternion conversions of pybullet's rigid group (no pybullet here).

Bullet takes a DIAGONAL body inertia (`changeDynamics(localInertiaDiagonal=...)`). A scene's
body-frame tensor I0 = P diag(d) P^T (numpy `eigh`, P made a proper rotation) is simulated by
a body whose frame is P's columns: the engine's orientation is q_engine = q_scene (x) q(P) and
the scene's is recovered as q_scene = q_engine (x) conj(q(P)). Everything is vectorised over
bodies. Quaternion layouts: the scene's (w, x, y, z), pybullet's (x, y, z, w).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def xyzw_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a (x) b of (..., 4) quaternions stored (x, y, z, w)."""
    av, aw = a[..., :3], a[..., 3:]
    bv, bw = b[..., :3], b[..., 3:]
    vector = aw * bv + bw * av + np.cross(av, bv)
    scalar = aw * bw - np.sum(av * bv, axis=-1, keepdims=True)
    return np.concatenate([vector, scalar], axis=-1)


def wxyz_to_xyzw(q: np.ndarray) -> np.ndarray:
    return np.roll(np.asarray(q, float), -1, axis=-1)


def xyzw_to_wxyz(q: np.ndarray) -> np.ndarray:
    return np.roll(np.asarray(q, float), 1, axis=-1)


def conjugate_xyzw(q: np.ndarray) -> np.ndarray:
    return np.concatenate([-q[..., :3], q[..., 3:]], axis=-1)


def matrices_to_xyzw(rot: np.ndarray) -> np.ndarray:
    """Unit quaternions (x, y, z, w) of (n, 3, 3) proper rotations (scipy's conversion)."""
    from scipy.spatial.transform import Rotation
    return Rotation.from_matrix(rot).as_quat()


def xyzw_to_matrices(q: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations of (n, 4) quaternions (x, y, z, w), read as unit (scipy divides by
    |q|): the orientation defect |q|^2 - 1 is read before this, on the raw values."""
    from scipy.spatial.transform import Rotation
    return Rotation.from_quat(q).as_matrix()


@dataclass(frozen=True)
class PrincipalFrames:
    """moments (n, 3): the principal moments d, ascending; axes (n, 3, 3): P, columns the
    principal axes in the scene's body frame, det P = +1; q_axes (n, 4): q(P), (x, y, z, w)."""

    moments: np.ndarray
    axes: np.ndarray
    q_axes: np.ndarray

    @classmethod
    def of(cls, inertia: np.ndarray) -> PrincipalFrames:
        moments, axes = np.linalg.eigh(np.asarray(inertia, float))
        improper = np.linalg.det(axes) < 0
        axes[improper, :, 2] *= -1.0  # flip one axis: a proper rotation, same diagonal form
        return cls(moments, axes, matrices_to_xyzw(axes))

    def engine_orientation(self, q_scene_wxyz: np.ndarray) -> np.ndarray:
        """(n, 4) (x, y, z, w): q_scene (x) q(P), the principal frame's orientation."""
        return xyzw_product(wxyz_to_xyzw(q_scene_wxyz), self.q_axes)

    def scene_orientation(self, q_engine_xyzw: np.ndarray) -> np.ndarray:
        """(n, 4) (w, x, y, z): q_engine (x) conj(q(P)), the scene body frame's orientation."""
        return xyzw_to_wxyz(xyzw_product(q_engine_xyzw, conjugate_xyzw(self.q_axes)))


def world_inertia(rot: np.ndarray, inertia: np.ndarray) -> np.ndarray:
    """I_w = R I0 R^T for (n, 3, 3) rotations and body-frame tensors."""
    return rot @ inertia @ np.swapaxes(rot, -1, -2)


def rigid_energy(mass, inertia_world, x, v, w, gravity) -> np.ndarray:
    """(n,) E = 1/2 m |v|^2 + 1/2 w . I_w w - m g . x per body."""
    spin = np.einsum("ni,nij,nj->n", w, inertia_world, w)
    return 0.5 * mass * np.sum(v * v, axis=1) + 0.5 * spin - mass * (x @ np.asarray(gravity))
