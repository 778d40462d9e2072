"""Engine-neutral scene description: frozen, validated plain data.

Every backend (the in-house engine and each adapter) reads the same `Scene`. SI units, float64;
3D scenes are z-up, 2D scenes are y-up. Validation happens when an object is built: a bad value
raises `ValueError` naming the field and its valid range, never later inside an engine.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

Vec = tuple[float, float, float]


def _vec(name: str, value) -> Vec:
    arr = np.asarray(value, dtype=float).reshape(-1)
    if arr.shape != (3,):
        raise ValueError(f"{name} must have 3 components, got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {tuple(arr)}")
    return tuple(float(c) for c in arr)


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be a finite number > 0, got {value}")
    return value


def _nonnegative(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value) or value < 0:
        raise ValueError(f"{name} must be a finite number >= 0, got {value}")
    return value


def _set(obj, name: str, value) -> None:
    object.__setattr__(obj, name, value)


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


@dataclass(frozen=True)
class Spring:
    """Linear spring from body `body` to a fixed `anchor` (or to body `other` when given)."""

    body: int
    stiffness: float
    rest_length: float
    anchor: Vec = (0.0, 0.0, 0.0)
    other: int | None = None
    damping: float = 0.0

    def __post_init__(self):
        _set(self, "stiffness", _positive("spring.stiffness", self.stiffness))
        _set(self, "rest_length", _nonnegative("spring.rest_length", self.rest_length))
        _set(self, "damping", _nonnegative("spring.damping", self.damping))
        _set(self, "anchor", _vec("spring.anchor", self.anchor))


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


@dataclass(frozen=True)
class FluidBlock:
    """A 2D block of liquid [x0, x1] x [y0, y1] (m) sampled at `spacing`, at rest and in
    hydrostatic balance at t = 0, inside a rectangular `tank` [0, tank_width] x [0,
    tank_height] with solid walls. Weakly compressible: sound speed c0; Monaghan's artificial
    viscosity alpha; smoothing length h = smoothing * spacing. `no_slip`: the artificial
    viscosity also acts between fluid and wall particles (a numerical no-slip wall whose
    effective viscosity alpha c0 h / 8 shrinks with the resolution); otherwise the walls act
    through pressure only (free-slip). `delta`: the delta-SPH density diffusion coefficient
    (Molteni & Colagrossi 2009; 0 = none). `tension`: the pressure follows the equation of
    state below rho0 too (negative pressure holds the fluid together); otherwise it is
    clamped at 0 there."""

    lower: tuple[float, float]
    upper: tuple[float, float]
    spacing: float
    tank_width: float
    tank_height: float
    density: float = 1000.0
    sound_speed: float = 20.0
    viscosity_alpha: float = 0.02
    smoothing: float = 1.3
    no_slip: bool = False
    delta: float = 0.0
    tension: bool = False

    def __post_init__(self):
        _set(self, "no_slip", bool(self.no_slip))
        _set(self, "tension", bool(self.tension))
        _set(self, "delta", _nonnegative("fluid.delta", self.delta))
        for name in ("spacing", "tank_width", "tank_height", "density", "sound_speed",
                     "smoothing"):
            _set(self, name, _positive(f"fluid.{name}", getattr(self, name)))
        _set(self, "viscosity_alpha", _nonnegative("fluid.viscosity_alpha",
                                                   self.viscosity_alpha))
        lo, hi = tuple(map(float, self.lower)), tuple(map(float, self.upper))
        if len(lo) != 2 or len(hi) != 2 or not all(a < b for a, b in zip(lo, hi)):
            raise ValueError(f"fluid block must have lower < upper in 2D, got {lo}, {hi}")
        if lo[0] < 0 or lo[1] < 0 or hi[0] > self.tank_width or hi[1] > self.tank_height:
            raise ValueError("fluid block must lie inside the tank")
        _set(self, "lower", lo)
        _set(self, "upper", hi)


@dataclass(frozen=True)
class Scene:
    bodies: tuple[Body, ...]
    gravity: Vec = (0.0, 0.0, 0.0)
    springs: tuple[Spring, ...] = ()
    joints: tuple[Joint, ...] = ()
    linear_drag: float = 0.0
    walls: tuple[Wall, ...] = ()
    contact: ContactModel | None = None
    fluid: FluidBlock | None = None
    dim: int = 3
    planar: bool = False
    meta: dict = field(default_factory=dict, compare=False)

    def __post_init__(self):
        if not self.bodies and self.fluid is None:
            raise ValueError("scene.bodies must hold at least one body (or the scene a fluid)")
        _set(self, "gravity", _vec("scene.gravity", self.gravity))
        _set(self, "linear_drag", _nonnegative("scene.linear_drag", self.linear_drag))
        if self.dim not in (2, 3):
            raise ValueError(f"scene.dim must be 2 or 3, got {self.dim}")
        n = len(self.bodies)
        for s in self.springs:
            for idx in (s.body, s.other):
                if idx is not None and not 0 <= idx < n:
                    raise ValueError(f"spring body index must be in [0, {n - 1}], got {idx}")
        for j in self.joints:
            if not 0 <= j.body < n:
                raise ValueError(f"joint body index must be in [0, {n - 1}], got {j.body}")

    def features(self) -> set[str]:
        """What the scene needs simulated; engines build their step from this only."""
        out = set()
        if any(self.gravity):
            out.add("gravity")
        if self.springs:
            out.add("springs")
        if self.joints:
            out.add("joints")
        if self.linear_drag > 0:
            out.add("drag")
        if self.contact is not None:
            out.add("contacts")
        if self.walls:
            out.add("walls")
        if self.fluid is not None:
            out |= {"fluid", "walls"}
        return out

    def stays_in_plane(self, normal_axis: int) -> bool:
        """True when every body's motion stays in the coordinate plane through the origin
        normal to axis `normal_axis` (0, 1, 2): no position, velocity, force, anchor or wall
        normal out of it, spins only about the normal, hinges about the normal."""
        k = normal_axis
        others = [a for a in range(3) if a != k]
        if self.gravity[k] != 0:
            return False
        if any(b.position[k] != 0 or b.velocity[k] != 0 for b in self.bodies):
            return False
        if any(s.anchor[k] != 0 for s in self.springs):
            return False
        if any(w.normal[k] != 0 for w in self.walls):
            return False
        if any(b.angular_velocity[a] != 0 for b in self.bodies for a in others):
            return False
        return all(j.anchor[k] == 0 and abs(j.axis[k]) == 1.0 for j in self.joints)

    def stays_in_xz_plane(self) -> bool:
        """True when every body's motion stays in the x-z plane (y = 0, no y velocity or force)."""
        return self.stays_in_plane(1)

    @property
    def masses(self) -> np.ndarray:
        return np.array([b.mass for b in self.bodies])

    @property
    def positions(self) -> np.ndarray:
        return np.array([b.position for b in self.bodies])

    @property
    def velocities(self) -> np.ndarray:
        return np.array([b.velocity for b in self.bodies])

    @property
    def radii(self) -> np.ndarray:
        return np.array([b.radius for b in self.bodies])

    @property
    def inertias(self) -> np.ndarray:
        return np.array([b.inertia for b in self.bodies])

    @property
    def angular_velocities(self) -> np.ndarray:
        return np.array([b.angular_velocity for b in self.bodies])
