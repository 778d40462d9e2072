"""The `Scene` container: the parts of one scenario, validated together.

Records in, arrays kept. A case passes bodies, springs, joints and walls as tuples of frozen
records (`Body`, `Spring`, `Joint`, `Wall`) or as their array part (`Particles`, `Springs`,
`Joints`, `Walls`). The scene converts them ONCE into both forms and keeps both:
- `scene.bodies`, `scene.springs`, `scene.joints`, `scene.walls`: tuples of records (for the
  adapters' build-time translation);
- `scene.particles`, `scene.spring_set`, `scene.joint_set`, `scene.wall_set`: the parts, as
  read-only numpy arrays; `scene.masses`, `positions`, `velocities`, `radii`, `inertias` and
  `angular_velocities` return the particles' stored arrays (no copy, no rebuild: never write
  into them; copy first).
The new parts are given as parts: `rigid` (RigidBodies), `networks` (SpringNetwork, ...),
`meshes` (TriangleMesh, ...), `grids` (Grid, ...); `fluid` is the SPH `FluidBlock`.

Parts of a kind the core does not know (a plugin's or a new model group's own part, in its own
module) go in `extra`: any frozen object with a `kind` (a name not in PART_KINDS), `features()`
and, if it moves, `moving = True`. They count in `parts()`, `part_kinds()` and `features()`
like the built-in ones, so a new part kind is a new file, not an edit here.

One moving kind: a scene's observed "x"/"v" (refsim.observation) belong to one kind of moving
bodies, MOVING_KINDS: particles, an SPH fluid, rigid bodies, spring-network nodes or mesh nodes.
A scene that mixes two of them is rejected. Grids move nothing and go with any kind.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._validate import Vec, _nonnegative, _set, _vec
from .fluid import FluidBlock
from .grids import Grid
from .joints import Joint, Joints, check_joint_bodies
from .meshes import TriangleMesh
from .networks import SpringNetwork
from .particles import Body, Particles
from .rigid import RigidBodies
from .springs import Spring, Springs, check_spring_bodies
from .walls import ContactModel, Wall, Walls

PART_KINDS = ("particles", "springs", "joints", "walls", "fluid", "rigid", "networks",
              "meshes", "grids")
MOVING_KINDS = ("particles", "fluid", "rigid", "networks", "meshes")

# record-tuple field -> (part attribute, part class)
_RECORD_PARTS = {"bodies": ("particles", Particles), "springs": ("spring_set", Springs),
                 "joints": ("joint_set", Joints), "walls": ("wall_set", Walls)}


def _records_and_part(value, part_cls):
    """(records, part) from a tuple of records or from the part. A given part is turned into
    records and back, so that both forms hold exactly the records' values."""
    records = value.to_records() if isinstance(value, part_cls) else tuple(value)
    return records, part_cls.from_records(records)


def _extra_parts(value) -> tuple:
    """Parts of kinds the core does not know: each frozen, with a new `kind` and features()."""
    items = tuple(value) if isinstance(value, (tuple, list)) else (value,)
    for item in items:
        kind = getattr(item, "kind", None)
        if not isinstance(kind, str) or not kind or kind in PART_KINDS:
            raise ValueError(f"scene.extra parts must each have a `kind` not in {PART_KINDS}, "
                             f"got {kind!r}")
        if not callable(getattr(item, "features", None)):
            raise ValueError(f"scene.extra part {kind!r} must define features()")
        params = getattr(type(item), "__dataclass_params__", None)
        if params is None or not params.frozen:
            raise ValueError(f"scene.extra part {kind!r} must be a frozen dataclass")
    return items


def _tuple_of(name: str, value, part_cls) -> tuple:
    items = (value,) if isinstance(value, part_cls) else tuple(value)
    for item in items:
        if not isinstance(item, part_cls):
            raise ValueError(f"scene.{name} must hold {part_cls.__name__} parts, got "
                             f"{type(item).__name__}")
    return items


@dataclass(frozen=True)
class Scene:
    bodies: tuple[Body, ...] | Particles = ()
    gravity: Vec = (0.0, 0.0, 0.0)
    springs: tuple[Spring, ...] | Springs = ()
    joints: tuple[Joint, ...] | Joints = ()
    linear_drag: float = 0.0
    walls: tuple[Wall, ...] | Walls = ()
    contact: ContactModel | None = None
    fluid: FluidBlock | None = None
    dim: int = 3
    planar: bool = False
    meta: dict = field(default_factory=dict, compare=False)
    rigid: RigidBodies | None = None
    networks: tuple[SpringNetwork, ...] = ()
    meshes: tuple[TriangleMesh, ...] = ()
    grids: tuple[Grid, ...] = ()
    extra: tuple = ()
    particles: Particles = field(init=False, repr=False, compare=False)
    spring_set: Springs = field(init=False, repr=False, compare=False)
    joint_set: Joints = field(init=False, repr=False, compare=False)
    wall_set: Walls = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        for name, (part_name, part_cls) in _RECORD_PARTS.items():
            records, part = _records_and_part(getattr(self, name), part_cls)
            _set(self, name, records)
            _set(self, part_name, part)
        self._check_new_parts()
        if not self.bodies and self.fluid is None and not self._has_new_parts():
            raise ValueError("scene.bodies must hold at least one body (or the scene a fluid)")
        _set(self, "gravity", _vec("scene.gravity", self.gravity))
        _set(self, "linear_drag", _nonnegative("scene.linear_drag", self.linear_drag))
        if self.dim not in (2, 3):
            raise ValueError(f"scene.dim must be 2 or 3, got {self.dim}")
        n = len(self.bodies)
        check_spring_bodies(self.springs, n)
        check_joint_bodies(self.joints, n)
        self._check_one_moving_kind()

    def _check_new_parts(self) -> None:
        if self.rigid is not None and not isinstance(self.rigid, RigidBodies):
            raise ValueError(f"scene.rigid must be RigidBodies or None, got "
                             f"{type(self.rigid).__name__}")
        _set(self, "networks", _tuple_of("networks", self.networks, SpringNetwork))
        _set(self, "meshes", _tuple_of("meshes", self.meshes, TriangleMesh))
        grids = _tuple_of("grids", self.grids, Grid)
        _set(self, "grids", grids)
        _set(self, "extra", _extra_parts(self.extra))
        names = [name for g in grids for name in g.fields]
        if len(set(names)) != len(names):
            raise ValueError(f"scene.grids field names must be distinct across grids (each is "
                             f"observed as 'grid.<name>'), got {names}")

    def _has_new_parts(self) -> bool:
        return self.rigid is not None or bool(self.networks or self.meshes or self.grids
                                              or self.extra)

    def _check_one_moving_kind(self) -> None:
        moving = [k for k in MOVING_KINDS if k in self.part_kinds()]
        moving += [p.kind for p in self.extra if getattr(p, "moving", False)]
        if len(moving) > 1:
            raise ValueError(f"scene must hold one kind of moving bodies (its observed 'x', "
                             f"'v' belong to it), got {moving}")

    # -- parts and features -------------------------------------------------------------------
    def parts(self) -> tuple:
        """Every part present (non-empty), in PART_KINDS order."""
        singles = (self.particles, self.spring_set, self.joint_set, self.wall_set)
        out = [p for p in singles if len(p)]
        out += [p for p in (self.fluid, self.rigid) if p is not None]
        return tuple(out) + self.networks + self.meshes + self.grids + self.extra

    def part_kinds(self) -> set[str]:
        """The kinds (of PART_KINDS) of the parts present."""
        return {p.kind for p in self.parts()}

    def moving_kind(self) -> str | None:
        """The one kind of moving bodies (of MOVING_KINDS) whose "x", "v" are observed."""
        kinds = self.part_kinds()
        extra = [p.kind for p in self.extra if getattr(p, "moving", False)]
        return next((k for k in MOVING_KINDS if k in kinds), extra[0] if extra else None)

    def features(self) -> set[str]:
        """What the scene needs simulated; engines build their step from this only. Scene-wide:
        gravity (non-zero), drag (linear_drag > 0), contacts (a contact model); each part adds
        its own (springs, joints, walls; fluid + walls; rigid; networks; fem [+ plasticity];
        grid + the grid's model)."""
        out = set()
        if any(self.gravity):
            out.add("gravity")
        if self.linear_drag > 0:
            out.add("drag")
        if self.contact is not None:
            out.add("contacts")
        for part in self.parts():
            out |= part.features()
        return out

    # -- geometry ------------------------------------------------------------------------------
    def stays_in_plane(self, normal_axis: int) -> bool:
        """True when every body's motion stays in the coordinate plane through the origin
        normal to axis `normal_axis` (0, 1, 2): no position, velocity, force, anchor or wall
        normal out of it, spins only about the normal, hinges about the normal. Network and
        mesh nodes are checked like bodies; rigid bodies are not analysed (False)."""
        k = normal_axis
        others = [a for a in range(3) if a != k]
        p, j = self.particles, self.joint_set
        if self.gravity[k] != 0 or self.rigid is not None:
            return False
        out_of_plane = (p.position[:, k], p.velocity[:, k], self.spring_set.anchor[:, k],
                        self.wall_set.normal[:, k], p.angular_velocity[:, others],
                        j.anchor[:, k], np.abs(j.axis[:, k]) - 1.0)
        out_of_plane += tuple(a[:, k] for n in self.networks for a in (n.positions, n.velocities))
        out_of_plane += tuple(a[:, k] for m in self.meshes for a in (m.vertices, m.velocities))
        return not any(np.any(a != 0) for a in out_of_plane)

    def stays_in_xz_plane(self) -> bool:
        """True when every body's motion stays in the x-z plane (y = 0, no y velocity or force)."""
        return self.stays_in_plane(1)

    # -- the particles' arrays (stored, read-only) ----------------------------------------------
    @property
    def masses(self) -> np.ndarray:
        return self.particles.mass

    @property
    def positions(self) -> np.ndarray:
        return self.particles.position

    @property
    def velocities(self) -> np.ndarray:
        return self.particles.velocity

    @property
    def radii(self) -> np.ndarray:
        return self.particles.radius

    @property
    def inertias(self) -> np.ndarray:
        return self.particles.inertia

    @property
    def angular_velocities(self) -> np.ndarray:
        return self.particles.angular_velocity
