"""refsim's 3-vectors on pymunk's plane: a 3D scene's (x, z) or a 2D scene's (x, y)."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Plane:
    """The mapping for a scene of dimension `dim`: 3D scenes keep their x-z plane (y-up in
    pymunk, observed y = 0), 2D scenes their x-y plane (observed z = 0)."""

    dim: int

    @property
    def axes(self) -> tuple[int, int]:
        """The refsim axes that become pymunk's (x, y)."""
        return (0, 2) if self.dim == 3 else (0, 1)

    @property
    def normal_axis(self) -> int:
        """The refsim axis normal to pymunk's plane: y for 3D (x-z plane), z for 2D (x-y)."""
        return 1 if self.dim == 3 else 2

    @property
    def spin_sign(self) -> float:
        """pymunk's rotation axis is its +z, x_pm cross y_pm; in a 3D scene that is refsim's
        x cross z = -y, so refsim's spin about +y is minus pymunk's angular velocity (a point
        at +x on a body spinning +w about y moves along -z: w y cross x = -w z). 2D: same
        axis."""
        return -1.0 if self.dim == 3 else 1.0

    def to2d(self, vec) -> tuple[float, float]:
        i, k = self.axes
        return (float(vec[i]), float(vec[k]))
