"""Thin static plates (issue 28, tunnelling): the `Plates` part (kind "plates").

p square slabs: `center` (p, 3) m, the mid-plane's centre; `normal` (p, 3) unit (normalised
here; a row already unit to round-off is kept), the slab's normal; `thickness` w (p,) m > 0,
the slab spans |(x - center).normal| <= w / 2; `half_size` (p,) m > 0, half the side of the
square in the mid-plane (the in-plane axes are any orthonormal pair perpendicular to the
normal: a square plate's contact with a sphere that hits it away from its rim does not depend
on them). A sphere of radius r touches a plate where its centre is within w / 2 + r of the
mid-plane and within the square. Plates do not move; the scene's contact model (restitution,
friction) applies to them as to walls. Feature "plates"; observed nothing of their own.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._validate import ArrayPart, _set, float_array, positive_array, unit_rows


@dataclass(frozen=True, eq=False)
class Plates(ArrayPart):
    center: np.ndarray
    normal: np.ndarray
    thickness: np.ndarray
    half_size: np.ndarray

    kind = "plates"

    def __post_init__(self):
        center = float_array("plates.center", np.reshape(self.center, (-1, 3)), (None, 3))
        n = len(center)
        _set(self, "center", center)
        normal = np.reshape(np.asarray(self.normal, float), (-1, 3))
        if normal.shape != center.shape:
            raise ValueError(f"plates.normal must have shape {center.shape}, got {normal.shape}")
        _set(self, "normal", unit_rows("plates.normal", normal))
        _set(self, "thickness", positive_array("plates.thickness",
                                               np.atleast_1d(self.thickness), (n,)))
        _set(self, "half_size", positive_array("plates.half_size",
                                               np.atleast_1d(self.half_size), (n,)))

    def __len__(self) -> int:
        return len(self.center)

    def features(self) -> set[str]:
        return {"plates"} if len(self) else set()
