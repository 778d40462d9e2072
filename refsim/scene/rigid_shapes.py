"""Collision shapes of rigid bodies: the `RigidShapes` part (geometry only).

A shape gives rigid body `body` a collision geometry in its body frame, centred on its centre of
mass: a "sphere" of `radius`, or a "cylinder" of `radius` and `half_length` whose axis is the
body-frame y axis. Mass and inertia stay the rigid part's (`RigidBodies`): a hoop is a cylinder
shape on a body with I = m r^2 about y, a solid disc the same shape with I = m r^2 / 2. Scenes
pass it in `Scene(parts=(RigidBodies(...), RigidShapes(...)))`; with walls and a `ContactModel` the
shapes touch the walls. Feature "shapes". Observables are the rigid part's (x, v, q, w:
refsim/observation.py).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._validate import ArrayPart, _set, float_array, positive_array, read_only

SHAPE_KINDS = ("sphere", "cylinder")
AXIS_TOL = 1e-12  # |y component| of a planar scene's vectors, and of R(q) y off world y: a
# unit quaternion rotates y exactly to a few ulps (~1e-16); 1e-12 is far below any real tilt


def _shape_kinds(value, count: int) -> tuple:
    kinds = (value,) if isinstance(value, str) else tuple(value)
    if len(kinds) != count:
        raise ValueError(f"rigid_shapes.shape must hold one kind per shape ({count}), got "
                         f"{len(kinds)}")
    bad = [k for k in kinds if k not in SHAPE_KINDS]
    if bad:
        raise ValueError(f"rigid_shapes.shape must be one of {list(SHAPE_KINDS)}, got "
                         f"{bad[0]!r}")
    return tuple(str(k) for k in kinds)


def _half_lengths(value, kinds: tuple) -> np.ndarray:
    """Cylinders > 0, spheres exactly 0."""
    half = float_array("rigid_shapes.half_length", value, (len(kinds),))
    cylinder = np.array([k == "cylinder" for k in kinds])
    if np.any(half[cylinder] <= 0):
        raise ValueError(f"rigid_shapes.half_length must be > 0 for a cylinder, got min "
                         f"{half[cylinder].min()}")
    if np.any(half[~cylinder] != 0):
        raise ValueError("rigid_shapes.half_length must be 0 for a sphere")
    return half


@dataclass(frozen=True, eq=False)
class RigidShapes(ArrayPart):
    """k shapes. body (k,) int, distinct, each an index of the scene's rigid bodies;
    shape (k,) tuple of "sphere" | "cylinder" (not named `kind`: that is the part kind,
    "rigid_shapes"); radius (k,) m > 0; half_length (k,) m, > 0 for a cylinder (axis along
    body-frame y), 0 for a sphere. Omitted half_length: zeros."""

    body: np.ndarray
    shape: tuple
    radius: np.ndarray
    half_length: np.ndarray | None = None

    kind = "rigid_shapes"

    def __post_init__(self):
        body = np.array(self.body, dtype=np.int64).reshape(-1)
        if len(body) == 0:
            raise ValueError("rigid_shapes.body must hold at least one body index")
        if np.any(body < 0):
            raise ValueError(f"rigid_shapes.body must be indices >= 0, got {body.tolist()}")
        if len(np.unique(body)) != len(body):
            raise ValueError(f"rigid_shapes.body must name each body at most once, got "
                             f"{body.tolist()}")
        k = len(body)
        _set(self, "body", read_only(body))
        kinds = _shape_kinds(self.shape, k)
        _set(self, "shape", kinds)
        _set(self, "radius", positive_array("rigid_shapes.radius", self.radius, (k,)))
        half = np.zeros(k) if self.half_length is None else self.half_length
        _set(self, "half_length", _half_lengths(half, kinds))

    def __len__(self) -> int:
        return len(self.body)

    def features(self) -> set[str]:
        return {"shapes"}


def check_shape_bodies(shapes: RigidShapes, rigid) -> None:
    """Every shape's body index names one of the scene's rigid bodies."""
    n = len(rigid)
    if np.any(shapes.body >= n):
        raise ValueError(f"rigid_shapes.body must be in [0, {n - 1}], got "
                         f"{shapes.body.tolist()}")


def rolling_scene_refusal(scene, who: str) -> str | None:
    """Why `who` (an adapter of the rolling group) cannot take the scene, or None: every body
    needs one shape, the walls a contact model, and the motion must stay in the x-z plane
    (gravity, positions, velocities, wall normals at y = 0, spins about y, each shape's axis
    and body y along world y)."""
    from .rigid import RigidBodies
    from .walls import Walls
    rigid, shapes, walls = scene.part(RigidBodies), scene.part(RigidShapes), scene.part(Walls)
    try:
        check_shape_bodies(shapes, rigid)
    except ValueError as exc:
        return f"{who}: {exc}"
    if len(shapes) != len(rigid):
        return f"{who}: every rigid body needs a shape (RigidShapes) in a rolling scene"
    if scene.contact is None or walls is None:
        return f"{who}: a rolling scene needs walls and a contact model (friction)"
    q = rigid.orientation
    w, u = q[:, :1], q[:, 1:]
    y = np.array([0.0, 1.0, 0.0])
    t = 2.0 * np.cross(u, np.broadcast_to(y, u.shape))
    axis = y + w * t + np.cross(u, t)  # R(q) y
    off_plane = (scene.gravity[1], rigid.position[:, 1], rigid.velocity[:, 1],
                 rigid.angular_velocity[:, [0, 2]], walls.normal[:, 1],
                 walls.point[:, 1], axis[:, [0, 2]])
    if any(np.any(np.abs(a) > AXIS_TOL) for a in off_plane):
        return (f"{who}: the rolling group runs planar motion only (x-z plane: y components "
                f"0, spins and each body's y axis along world y)")
    return None
