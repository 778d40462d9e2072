"""Static planes and the contact model: the `Wall` record, the `Walls` part (every wall of a
scene as read-only arrays) and `ContactModel` (restitution and friction of every contact)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._validate import ArrayPart, Vec, _nonnegative, _set, _vec, float_array, unit_rows


@dataclass(frozen=True)
class Wall:
    """An infinite plane through `point`; `normal` (normalised here) points into free space."""

    point: Vec
    normal: Vec

    def __post_init__(self):
        _set(self, "point", _vec("wall.point", self.point))
        normal = np.asarray(_vec("wall.normal", self.normal))
        if np.linalg.norm(normal) == 0:
            raise ValueError("wall.normal must be a non-zero vector")
        _set(self, "normal", tuple(float(c) for c in normal / np.linalg.norm(normal)))


@dataclass(frozen=True, eq=False)
class Walls(ArrayPart):
    """w infinite planes: point (w, 3) m on each plane; normal (w, 3) unit, pointing into
    free space (normalised here; a row already unit to round-off is kept as given)."""

    point: np.ndarray
    normal: np.ndarray

    kind = "walls"

    def __post_init__(self):
        point = float_array("walls.point", np.reshape(self.point, (-1, 3)), (None, 3))
        _set(self, "point", point)
        normal = np.asarray(self.normal, float)
        if normal.shape != point.shape:
            raise ValueError(f"walls.normal must have shape {point.shape}, got {normal.shape}")
        _set(self, "normal", unit_rows("walls.normal", normal))

    def __len__(self) -> int:
        return len(self.point)

    def features(self) -> set[str]:
        return {"walls"} if len(self) else set()

    @classmethod
    def from_records(cls, walls) -> "Walls":
        return cls(point=np.array([w.point for w in walls], float).reshape(-1, 3),
                   normal=np.array([w.normal for w in walls], float).reshape(-1, 3))

    def to_records(self) -> tuple[Wall, ...]:
        """One `Wall` per row, holding this part's normals exactly (already unit)."""
        return tuple(_wall(p, n) for p, n in zip(self.point, self.normal))


def _wall(point, normal) -> Wall:
    record = Wall(point=point, normal=normal)
    _set(record, "normal", tuple(float(c) for c in normal))  # no second normalisation
    return record


@dataclass(frozen=True)
class ContactModel:
    """Rigid contact between spheres (and with walls): coefficient of restitution e in [0, 1]
    (ratio of separating to approaching normal speed) and Coulomb friction mu >= 0."""

    restitution: float = 1.0
    friction: float = 0.0

    def __post_init__(self):
        e = float(self.restitution)
        if not math.isfinite(e) or not 0.0 <= e <= 1.0:
            raise ValueError(f"contact.restitution must be in [0, 1], got {e}")
        _set(self, "restitution", e)
        _set(self, "friction", _nonnegative("contact.friction", self.friction))
