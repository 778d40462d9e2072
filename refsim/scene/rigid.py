"""Rigid bodies with a full inertia tensor and an orientation (the `RigidBodies` part)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._validate import ArrayPart, _set, float_array, positive_array, read_only, zeros_or

QUATERNION_NORM_TOL = 1e-9  # |q| must be 1 within this; q is then stored divided by |q|
SYMMETRY_TOL = 1e-12  # |I - I^T| <= this * max |I| per body


def _inertia_tensors(value, n: int) -> np.ndarray:
    """(n, 3, 3) symmetric positive definite tensors; stored as 0.5 (I + I^T) (exact when I is
    exactly symmetric)."""
    inertia = float_array("rigid.inertia", value, (n, 3, 3))
    scale = np.abs(inertia).max(axis=(1, 2)) if n else np.zeros(0)
    asym = np.abs(inertia - inertia.transpose(0, 2, 1)).max(axis=(1, 2)) if n else scale
    if np.any(asym > SYMMETRY_TOL * scale):
        raise ValueError(f"rigid.inertia must be symmetric (to {SYMMETRY_TOL:g} relative), "
                         f"bodies {np.flatnonzero(asym > SYMMETRY_TOL * scale).tolist()} are not")
    sym = 0.5 * (inertia + inertia.transpose(0, 2, 1))
    if n and np.any(np.linalg.eigvalsh(sym)[:, 0] <= 0):
        raise ValueError("rigid.inertia must be positive definite (every principal moment > 0)")
    return read_only(sym)


def _unit_quaternions(value, n: int) -> np.ndarray:
    q = np.array(float_array("rigid.orientation", value, (n, 4)))
    norm = np.linalg.norm(q, axis=1)
    bad = np.abs(norm - 1.0) > QUATERNION_NORM_TOL
    if np.any(bad):
        raise ValueError(f"rigid.orientation must be unit quaternions (|q| = 1 within "
                         f"{QUATERNION_NORM_TOL:g}), got |q| = {norm[bad][0]!r}")
    return read_only(q / norm[:, None])


@dataclass(frozen=True, eq=False)
class RigidBodies(ArrayPart):
    """n rigid bodies. mass (n,) kg > 0; inertia (n, 3, 3) kg m^2, the body-frame inertia
    tensor about the centre of mass, symmetric positive definite; position (n, 3) m of the
    centre of mass; orientation (n, 4) unit quaternions (w, x, y, z), scalar first, rotating
    body-frame vectors into the world frame; velocity (n, 3) m/s of the centre of mass;
    angular_velocity (n, 3) rad/s in the world frame. Omitted velocities are zeros."""

    mass: np.ndarray
    inertia: np.ndarray
    position: np.ndarray
    orientation: np.ndarray
    velocity: np.ndarray | None = None
    angular_velocity: np.ndarray | None = None

    kind = "rigid"

    def __post_init__(self):
        mass = positive_array("rigid.mass", self.mass, (None,))
        n = len(mass)
        if n == 0:
            raise ValueError("rigid.mass must hold at least one body")
        _set(self, "mass", mass)
        _set(self, "inertia", _inertia_tensors(self.inertia, n))
        _set(self, "position", float_array("rigid.position", self.position, (n, 3)))
        _set(self, "orientation", _unit_quaternions(self.orientation, n))
        for name in ("velocity", "angular_velocity"):
            _set(self, name, zeros_or(f"rigid.{name}", getattr(self, name), (n, 3)))

    def __len__(self) -> int:
        return len(self.mass)

    def features(self) -> set[str]:
        return {"rigid"}
