"""Rigid massless rods from a fixed anchor to a body: the `Joint` record and the `Joints` part
(every joint of a scene as read-only arrays, row i = joint i)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._validate import (ArrayPart, Vec, _positive, _set, _vec, choice, float_array,
                        positive_array, read_only, unit_rows)

JOINT_KINDS = ("hinge",)


@dataclass(frozen=True)
class Joint:
    """A rigid massless rod of `length` from a fixed `anchor` to body `body`.

    kind "hinge": the rod turns about `axis` through the anchor (planar pendulum).
    """

    body: int
    anchor: Vec
    length: float
    axis: Vec = (0.0, 1.0, 0.0)
    kind: str = "hinge"

    def __post_init__(self):
        _set(self, "length", _positive("joint.length", self.length))
        _set(self, "anchor", _vec("joint.anchor", self.anchor))
        axis = np.asarray(_vec("joint.axis", self.axis))
        if np.linalg.norm(axis) == 0:
            raise ValueError("joint.axis must be a non-zero vector")
        _set(self, "axis", tuple(float(c) for c in axis / np.linalg.norm(axis)))
        if self.kind != "hinge":
            raise ValueError(f"joint.kind must be one of ['hinge'], got {self.kind!r}")


def check_joint_bodies(joints, n: int) -> None:
    """Each joint's body must index one of the scene's n bodies."""
    for j in joints:
        if not 0 <= j.body < n:
            raise ValueError(f"joint body index must be in [0, {n - 1}], got {j.body}")


@dataclass(frozen=True, eq=False)
class Joints(ArrayPart):
    """k rods. body (k,) int; anchor (k, 3) m; length (k,) m > 0; axis (k, 3) unit (normalised
    here) the hinge axis through the anchor; kinds (k,) tuple, each one of JOINT_KINDS."""

    body: np.ndarray
    anchor: np.ndarray
    length: np.ndarray
    axis: np.ndarray
    kinds: tuple[str, ...]

    kind = "joints"

    def __post_init__(self):
        body = read_only(np.array(self.body, dtype=np.int64).reshape(-1))
        k = len(body)
        _set(self, "body", body)
        _set(self, "anchor", float_array("joints.anchor", self.anchor, (k, 3)))
        _set(self, "length", positive_array("joints.length", self.length, (k,)))
        _set(self, "axis", unit_rows("joints.axis", np.reshape(self.axis, (k, 3))))
        kinds = tuple(choice("joints.kinds", str(c), JOINT_KINDS) for c in self.kinds)
        if len(kinds) != k:
            raise ValueError(f"joints.kinds must have {k} entries, got {len(kinds)}")
        _set(self, "kinds", kinds)

    def __len__(self) -> int:
        return len(self.body)

    def features(self) -> set[str]:
        return {"joints"} if len(self) else set()

    @classmethod
    def from_records(cls, joints) -> "Joints":
        return cls(body=np.array([j.body for j in joints], np.int64),
                   anchor=np.array([j.anchor for j in joints], float).reshape(-1, 3),
                   length=np.array([j.length for j in joints], float),
                   axis=np.array([j.axis for j in joints], float).reshape(-1, 3),
                   kinds=tuple(j.kind for j in joints))

    def to_records(self) -> tuple[Joint, ...]:
        """One `Joint` per row, holding this part's axes exactly (already unit)."""
        return tuple(_joint(int(b), a, n, u, c) for b, a, n, u, c in
                     zip(self.body, self.anchor, self.length, self.axis, self.kinds))


def _joint(body, anchor, length, axis, kind) -> Joint:
    record = Joint(body=body, anchor=anchor, length=length, axis=axis, kind=kind)
    _set(record, "axis", tuple(float(c) for c in axis))  # no second normalisation
    return record
