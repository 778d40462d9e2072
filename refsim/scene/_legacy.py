"""TRANSITION ONLY (issue 24, item 2; removed when every caller uses parts): the keywords and
attributes of the Scene before `Scene(parts=...)` and `scene.part(Kind)`, mapped onto the parts.
Nothing is stored twice: every attribute here is computed from `scene.parts`."""
from __future__ import annotations

import numpy as np

from .fluid import FluidBlock
from .grids import Grid
from .joints import Joints
from .meshes import TriangleMesh
from .networks import SpringNetwork
from .particles import Particles
from .rigid import RigidBodies
from .scene import PART_KINDS, Scene
from .springs import Springs
from .walls import Walls

_RECORDS = {"bodies": Particles, "springs": Springs, "joints": Joints, "walls": Walls}
_SINGLE = {"fluid": FluidBlock, "rigid": RigidBodies}
_MANY = {"networks": SpringNetwork, "meshes": TriangleMesh, "grids": Grid}
LEGACY = (*_RECORDS, *_SINGLE, *_MANY, "extra")


def _legacy_parts(kw: dict) -> tuple:
    out = []
    for name, cls in _RECORDS.items():
        if name in kw:
            out.append(cls.of(kw.pop(name)))
    for name in _SINGLE:
        if name in kw:
            out.append(kw.pop(name))
    for name in (*_MANY, "extra"):
        if name in kw:
            value = kw.pop(name)
            out += list(value) if isinstance(value, (tuple, list)) else [value]
    return tuple(out)


_init = Scene.__init__


def __init__(self, parts=(), *args, **kw):
    extra = _legacy_parts(kw)
    parts = (tuple(parts) if isinstance(parts, (tuple, list)) else (parts,)) + extra
    _init(self, parts, *args, **kw)


Scene.__init__ = __init__


def _empty(cls):
    return cls.from_records(())


for _name, _cls in _RECORDS.items():
    setattr(Scene, _name, property(
        lambda self, c=_cls: () if self.part(c) is None else self.part(c).to_records()))
for _name, _cls in zip(("particles", "spring_set", "joint_set", "wall_set"), _RECORDS.values()):
    setattr(Scene, _name, property(
        lambda self, c=_cls: _empty(c) if self.part(c) is None else self.part(c)))
for _name, _cls in _SINGLE.items():
    setattr(Scene, _name, property(lambda self, c=_cls: self.part(c)))
for _name, _cls in _MANY.items():
    setattr(Scene, _name, property(lambda self, c=_cls: self.parts_of(c)))
Scene.extra = property(lambda self: tuple(p for p in self.parts if p.kind not in PART_KINDS))
for _name, _attr in (("masses", "mass"), ("positions", "position"), ("velocities", "velocity"),
                     ("radii", "radius"), ("inertias", "inertia"),
                     ("angular_velocities", "angular_velocity")):
    setattr(Scene, _name, property(lambda self, a=_attr: getattr(self.particles, a)))
_ = np
