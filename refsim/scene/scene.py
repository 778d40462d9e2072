"""The `Scene` container: the parts of one scenario, validated together.

One way in, one way out. A scene is built from its parts,

    Scene(parts=(Particles.of(bodies), Springs.of(springs), GravityPairs()), gravity=(0, 0, -9.81))

and a part is asked for by its class: `scene.part(Springs)` (the part, or None when the scene has
none; a ValueError where the scene holds several of that class) and `scene.parts_of(Grid)` (every
part of that class, in order: networks, meshes and grids may come several to a scene). Each part
is stored once, as given (frozen, read-only arrays); record tuples are made on demand
(`scene.part(Springs).to_records()`), never stored beside the arrays.

A part is any frozen dataclass with a `kind` (a name) and `features()`; the core's parts are in
this package, one module each (particles, springs, joints, walls, fluid, rigid, networks, meshes,
grids, gravity_pairs, lennard_jones, flocking, emitter, velocity_field, surface_sampling, pivots,
rigid_shapes), and a plugin's part of a new kind is a new file, not an edit here. A part class
sets `many = True` where a scene may hold several (networks, meshes, grids); otherwise at most one
per class. None entries and array parts of length 0 are dropped and nested tuples flattened (a
case may write `parts=(particles, springs if k > 0 else None, networks)`).

Scene-wide settings are fields: gravity, linear_drag, contact (the contact model between
spheres and walls), dim, planar, meta.

One moving kind: a scene's observed "x"/"v" (refsim.observation) belong to one kind of moving
bodies, MOVING_KINDS: particles, an SPH fluid, rigid bodies, spring-network nodes, mesh nodes (or
a plugin part with `moving = True`, such as the emitter's particles). A scene that mixes two of
them is rejected. Grids move nothing and go with any kind.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._validate import Vec, _nonnegative, _set, _vec
from .joints import Joints
from .particles import Particles
from .springs import Springs
from .walls import ContactModel, Walls

PART_KINDS = ("particles", "springs", "joints", "walls", "fluid", "rigid", "networks",
              "meshes", "grids", "fluid_grids")
MOVING_KINDS = ("particles", "fluid", "rigid", "networks", "meshes")
# parts that only act on bodies held by other parts: a scene of these alone has nothing to move
_ATTACHED_KINDS = ("springs", "joints", "walls", "plates")


def _rank(part) -> int:
    return PART_KINDS.index(part.kind) if part.kind in PART_KINDS else len(PART_KINDS)


def _checked_parts(value) -> tuple:
    """The parts as given (nested tuples flattened, None and empty array parts dropped), each a
    frozen dataclass with a `kind` and features(), at most one per class unless `many`, in a
    stable order: the core kinds in PART_KINDS order, then the others as given."""
    def flat(v):
        for item in (v if isinstance(v, (tuple, list)) else (v,)):
            yield from (flat(item) if isinstance(item, (tuple, list)) else (item,))
    out = []
    for item in flat(value):
        if item is None or (hasattr(item, "__len__") and len(item) == 0):
            continue
        kind = getattr(item, "kind", None)
        if not isinstance(kind, str) or not kind:
            raise ValueError(f"scene.parts must hold parts (each with a `kind`), got "
                             f"{type(item).__name__}")
        if not callable(getattr(item, "features", None)):
            raise ValueError(f"scene.parts: part {kind!r} must define features()")
        params = getattr(type(item), "__dataclass_params__", None)
        if params is None or not params.frozen:
            raise ValueError(f"scene.parts: part {kind!r} must be a frozen dataclass")
        out.append(item)
    for cls in {type(p) for p in out}:
        count = sum(type(p) is cls for p in out)
        if count > 1 and not getattr(cls, "many", False):
            raise ValueError(f"scene.parts must hold at most one {cls.__name__} part, got "
                             f"{count}")
    return tuple(sorted(out, key=_rank))


def _check_indices(name: str, idx: np.ndarray, n: int) -> None:
    idx = idx[idx >= 0] if name == "spring" else idx
    if idx.size and (idx.min() < 0 or idx.max() >= n):
        bad = idx[(idx < 0) | (idx >= n)][0]
        raise ValueError(f"{name} body index must be in [0, {n - 1}], got {bad}")


@dataclass(frozen=True)
class Scene:
    parts: tuple = ()
    gravity: Vec = (0.0, 0.0, 0.0)
    linear_drag: float = 0.0
    contact: ContactModel | None = None
    dim: int = 3
    planar: bool = False
    meta: dict = field(default_factory=dict, compare=False)

    def __post_init__(self):
        _set(self, "parts", _checked_parts(self.parts))
        if not any(p.kind not in _ATTACHED_KINDS for p in self.parts):
            raise ValueError("scene.parts must hold at least one part with bodies (particles, "
                             "a fluid, rigid bodies, a network, a mesh, a grid or a plugin's "
                             "part), got none")
        _set(self, "gravity", _vec("scene.gravity", self.gravity))
        _set(self, "linear_drag", _nonnegative("scene.linear_drag", self.linear_drag))
        if self.contact is not None and not isinstance(self.contact, ContactModel):
            raise ValueError(f"scene.contact must be a ContactModel or None, got "
                             f"{type(self.contact).__name__}")
        if self.dim not in (2, 3):
            raise ValueError(f"scene.dim must be 2 or 3, got {self.dim}")
        particles = self.part(Particles)
        n = 0 if particles is None else len(particles)
        springs, joints = self.part(Springs), self.part(Joints)
        if springs is not None:
            _check_indices("spring", np.concatenate([springs.body, springs.other]), n)
        if joints is not None:
            _check_indices("joint", joints.body, n)
        names = [name for p in self.parts if p.kind == "grids" for name in p.fields]
        if len(set(names)) != len(names):
            raise ValueError(f"scene grids' field names must be distinct across grids (each is "
                             f"observed as 'grid.<name>'), got {names}")
        moving = sorted({p.kind for p in self.parts
                         if p.kind in MOVING_KINDS or getattr(p, "moving", False)})
        if len(moving) > 1:
            raise ValueError(f"scene must hold one kind of moving bodies (its observed 'x', "
                             f"'v' belong to it), got {moving}")

    # -- asking for parts ---------------------------------------------------------------------
    def part(self, cls):
        """The scene's part of class `cls` (or a subclass), None when it has none; a ValueError
        where it holds several (ask with `parts_of`)."""
        found = self.parts_of(cls)
        if len(found) > 1:
            raise ValueError(f"scene holds {len(found)} {cls.__name__} parts: ask for them with "
                             f"scene.parts_of({cls.__name__})")
        return found[0] if found else None

    def parts_of(self, cls) -> tuple:
        """Every part of class `cls` (or a subclass), in the scene's order."""
        return tuple(p for p in self.parts if isinstance(p, cls))

    def with_part(self, part) -> "Scene":
        """This scene with `part` in place of the part(s) of its class (added if none)."""
        kept = tuple(p for p in self.parts if type(p) is not type(part))
        return Scene(parts=kept + (part,), gravity=self.gravity, linear_drag=self.linear_drag,
                     contact=self.contact, dim=self.dim, planar=self.planar, meta=self.meta)

    def part_kinds(self) -> set[str]:
        """The kinds of the parts present."""
        return {p.kind for p in self.parts}

    def moving_kind(self) -> str | None:
        """The one kind of moving bodies (of MOVING_KINDS, or a plugin part's) whose "x", "v"
        are observed; None for a scene of grids only."""
        return next((p.kind for p in self.parts
                     if p.kind in MOVING_KINDS or getattr(p, "moving", False)), None)

    def features(self) -> set[str]:
        """What the scene needs simulated; engines build their step from this only. Scene-wide:
        gravity (non-zero), drag (linear_drag > 0), contacts (a contact model); each part adds
        its own (springs, joints, walls; fluid + walls; rigid; networks; fem [+ plasticity];
        grid + the grid's model; gravity_pairs, ...)."""
        out = set()
        if any(self.gravity):
            out.add("gravity")
        if self.linear_drag > 0:
            out.add("drag")
        if self.contact is not None:
            out.add("contacts")
        for part in self.parts:
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
        if self.gravity[k] != 0 or "rigid" in self.part_kinds():
            return False
        out_of_plane = []
        p, s, j, w = (self.part(c) for c in (Particles, Springs, Joints, Walls))
        if p is not None:
            out_of_plane += [p.position[:, k], p.velocity[:, k], p.angular_velocity[:, others]]
        if s is not None:
            out_of_plane.append(s.anchor[:, k])
        if w is not None:
            out_of_plane.append(w.normal[:, k])
        if j is not None:
            out_of_plane += [j.anchor[:, k], np.abs(j.axis[:, k]) - 1.0]
        for part in self.parts:
            if part.kind == "networks":
                out_of_plane += [part.positions[:, k], part.velocities[:, k]]
            elif part.kind == "meshes":
                out_of_plane += [part.vertices[:, k], part.velocities[:, k]]
        return not any(np.any(a != 0) for a in out_of_plane)

    def stays_in_xz_plane(self) -> bool:
        """True when every body's motion stays in the x-z plane (y = 0, no y velocity or force)."""
        return self.stays_in_plane(1)
