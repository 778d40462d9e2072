"""Point masses and spheres: the `Body` record (one body, as cases write it) and the
`Particles` part (every body of a scene as read-only arrays, row i = body i)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._validate import (ArrayPart, Vec, _nonnegative, _positive, _set, _vec, float_array,
                        nonnegative_array, positive_array, zeros_or)


@dataclass(frozen=True)
class Body:
    """A point mass (radius 0) or a sphere. `inertia` is the scalar moment about the centre."""

    mass: float
    position: Vec
    velocity: Vec = (0.0, 0.0, 0.0)
    radius: float = 0.0
    inertia: float = 0.0
    angular_velocity: Vec = (0.0, 0.0, 0.0)
    name: str = "body"

    def __post_init__(self):
        _set(self, "mass", _positive(f"{self.name}.mass", self.mass))
        _set(self, "radius", _nonnegative(f"{self.name}.radius", self.radius))
        _set(self, "inertia", _nonnegative(f"{self.name}.inertia", self.inertia))
        for attr in ("position", "velocity", "angular_velocity"):
            _set(self, attr, _vec(f"{self.name}.{attr}", getattr(self, attr)))


@dataclass(frozen=True, eq=False)
class Particles(ArrayPart):
    """n point masses or spheres. mass (n,) kg > 0; position (n, 3) m; velocity (n, 3) m/s;
    radius (n,) m >= 0 (0: a point); inertia (n,) kg m^2 >= 0, the scalar moment of a sphere
    about its centre; angular_velocity (n, 3) rad/s, world frame. Omitted arrays are zeros."""

    mass: np.ndarray
    position: np.ndarray
    velocity: np.ndarray | None = None
    radius: np.ndarray | None = None
    inertia: np.ndarray | None = None
    angular_velocity: np.ndarray | None = None

    kind = "particles"

    def __post_init__(self):
        mass = positive_array("particles.mass", self.mass, (None,))
        n = len(mass)
        _set(self, "mass", mass)
        _set(self, "position", float_array("particles.position", self.position, (n, 3)))
        for name in ("velocity", "angular_velocity"):
            _set(self, name, zeros_or(f"particles.{name}", getattr(self, name), (n, 3)))
        for name in ("radius", "inertia"):
            value = getattr(self, name)
            _set(self, name, nonnegative_array(f"particles.{name}",
                                               np.zeros(n) if value is None else value, (n,)))

    def __len__(self) -> int:
        return len(self.mass)

    @classmethod
    def from_records(cls, bodies) -> "Particles":
        """The arrays of a tuple of `Body` records (values copied exactly)."""
        return cls(mass=np.array([b.mass for b in bodies], float),
                   position=np.array([b.position for b in bodies], float).reshape(-1, 3),
                   velocity=np.array([b.velocity for b in bodies], float).reshape(-1, 3),
                   radius=np.array([b.radius for b in bodies], float),
                   inertia=np.array([b.inertia for b in bodies], float),
                   angular_velocity=np.array([b.angular_velocity for b in bodies],
                                             float).reshape(-1, 3))

    def to_records(self) -> tuple[Body, ...]:
        """One `Body` per row (for build-time translation in adapters)."""
        rows = zip(self.mass, self.position, self.velocity, self.radius, self.inertia,
                   self.angular_velocity)
        return tuple(Body(mass=m, position=x, velocity=v, radius=r, inertia=i,
                          angular_velocity=w) for m, x, v, r, i, w in rows)
