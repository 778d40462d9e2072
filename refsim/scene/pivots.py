"""Rigid bodies held at one point: the `RigidPivots` part (ball joints to the world).

A pivot fixes the point `body_point` of rigid body `body` (body frame, metres from the centre of
mass) at the world point `anchor`: the body may turn freely about it (a spherical joint; a
planar scene whose bodies spin about one axis only makes it a hinge about that axis). Scenes
pass it in `Scene(parts=(RigidBodies(...), RigidPivots(...)))`; a body has at most one pivot, and at
t = 0 its body point must sit on the anchor (`check_on_anchor`, from the rigid part's state).
Observables are the rigid part's (x, v, q, w: refsim/observation.py).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._validate import ArrayPart, _set, float_array, read_only

ANCHOR_TOL = 1e-9  # m per m of body_point: |R(q0) body_point + x0 - anchor| at t = 0


@dataclass(frozen=True, eq=False)
class RigidPivots(ArrayPart):
    """k pivots. body (k,) int, distinct, each an index of the scene's rigid bodies;
    body_point (k, 3) m, body frame, from the centre of mass; anchor (k, 3) m, world frame."""

    body: np.ndarray
    body_point: np.ndarray
    anchor: np.ndarray

    kind = "rigid_pivots"

    def __post_init__(self):
        body = np.array(self.body, dtype=np.int64).reshape(-1)
        if len(body) == 0:
            raise ValueError("rigid_pivots.body must hold at least one body index")
        if np.any(body < 0):
            raise ValueError(f"rigid_pivots.body must be indices >= 0, got {body.tolist()}")
        if len(np.unique(body)) != len(body):
            raise ValueError(f"rigid_pivots.body must name each body at most once, got "
                             f"{body.tolist()}")
        k = len(body)
        _set(self, "body", read_only(body))
        _set(self, "body_point", float_array("rigid_pivots.body_point", self.body_point, (k, 3)))
        _set(self, "anchor", float_array("rigid_pivots.anchor", self.anchor, (k, 3)))

    def __len__(self) -> int:
        return len(self.body)

    def features(self) -> set[str]:
        return {"pivots"}


def check_on_anchor(pivots: RigidPivots, rigid) -> None:
    """Every pivot's body index exists and its body point sits on its anchor at t = 0."""
    n = len(rigid)
    if np.any(pivots.body >= n):
        raise ValueError(f"rigid_pivots.body must be in [0, {n - 1}], got "
                         f"{pivots.body.tolist()}")
    q = rigid.orientation[pivots.body]
    w, v = q[:, :1], q[:, 1:]
    p = pivots.body_point
    rotated = p + 2.0 * np.cross(v, np.cross(v, p) + w * p)  # q p q*
    gap = np.linalg.norm(rigid.position[pivots.body] + rotated - pivots.anchor, axis=1)
    scale = np.maximum(1.0, np.linalg.norm(p, axis=1))
    if np.any(gap > ANCHOR_TOL * scale):
        raise ValueError(f"rigid_pivots: body point must start on its anchor (within "
                         f"{ANCHOR_TOL:g} m per m), off by {gap.max():.3g} m")
