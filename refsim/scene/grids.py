"""Regular grids carrying fields, for finite differences (the `Grid` part)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from ._validate import ArrayPart, _positive, _set, choice, float_array

BOUNDARY_KINDS = ("dirichlet", "neumann", "periodic")
MIN_POINTS = 3


def _shape(value) -> tuple[int, ...]:
    shape = tuple(value)
    if not 1 <= len(shape) <= 3 or not all(isinstance(s, (int, np.integer)) for s in shape) \
            or min(shape) < MIN_POINTS:
        raise ValueError(f"grid.shape must be 1 to 3 integers >= {MIN_POINTS}, got {shape}")
    return tuple(int(s) for s in shape)


def _per_axis(name: str, value, ndim: int) -> tuple:
    items = (value,) * ndim if np.ndim(value) == 0 or isinstance(value, str) else tuple(value)
    if len(items) != ndim:
        raise ValueError(f"{name} must have one entry per axis ({ndim}), got {len(items)}")
    return items


def _boundary(value, ndim: int) -> tuple[tuple[str, str], ...]:
    """Per axis (low side, high side); a single kind applies to every side, a single pair to
    every axis; periodic on both sides of an axis or on neither."""
    if isinstance(value, str):
        value = (value, value)
    if len(value) == 2 and all(isinstance(v, str) for v in value):
        value = (tuple(value),) * ndim
    sides = _per_axis("grid.boundary", tuple(tuple(pair) for pair in value), ndim)
    for axis, pair in enumerate(sides):
        if len(pair) != 2:
            raise ValueError(f"grid.boundary[{axis}] must be a (low, high) pair, got {pair}")
        for kind in pair:
            choice(f"grid.boundary[{axis}]", kind, BOUNDARY_KINDS)
        if (pair[0] == "periodic") != (pair[1] == "periodic"):
            raise ValueError(f"grid.boundary[{axis}] must be periodic on both sides or on "
                             f"neither, got {pair}")
    return sides


def _fields(value, shape) -> MappingProxyType:
    if not value:
        raise ValueError("grid.fields must hold at least one initial field")
    out = {}
    for name, arr in dict(value).items():
        if not isinstance(name, str) or not name.isidentifier():
            raise ValueError(f"grid.fields names must be identifiers, got {name!r}")
        out[name] = float_array(f"grid.fields[{name!r}]", arr, shape)
    return MappingProxyType(out)


@dataclass(frozen=True, eq=False)
class Grid(ArrayPart):
    """A regular grid of `shape` points (1 to 3 axes, >= 3 points each) at `spacing` (m per
    axis, > 0) from `origin` (m, the first point); `boundary` per axis, (low, high) sides each
    one of BOUNDARY_KINDS ("dirichlet": the field keeps its initial values on that side's
    boundary points; "neumann": zero normal derivative; "periodic": on both sides or
    neither); `model` the equation it carries ("diffusion", "wave", "poisson", ...), also a
    scene feature; `coefficients` its named constants (e.g. {"diffusivity": 1e-4}), finite;
    `fields` {name: array of exactly `shape`, finite} the initial fields, observed as
    "grid.<name>"."""

    shape: tuple[int, ...]
    spacing: tuple[float, ...] | float
    model: str
    fields: dict
    boundary: tuple | str = "dirichlet"
    origin: tuple[float, ...] | float = 0.0
    coefficients: dict = field(default_factory=dict)

    kind = "grids"
    many = True  # a scene may hold several grids (field names distinct across them)

    def __post_init__(self):
        shape = _shape(self.shape)
        ndim = len(shape)
        _set(self, "shape", shape)
        _set(self, "spacing", tuple(_positive(f"grid.spacing[{k}]", h) for k, h in
                                    enumerate(_per_axis("grid.spacing", self.spacing, ndim))))
        _set(self, "origin", tuple(float_array("grid.origin", _per_axis(
            "grid.origin", self.origin, ndim), (ndim,)).tolist()))
        _set(self, "boundary", _boundary(self.boundary, ndim))
        if not isinstance(self.model, str) or not self.model.isidentifier():
            raise ValueError(f"grid.model must be a name such as 'diffusion', got {self.model!r}")
        _set(self, "fields", _fields(self.fields, shape))
        _set(self, "coefficients", MappingProxyType(_coefficients(self.coefficients)))

    def features(self) -> set[str]:
        return {"grid", self.model}


def _coefficients(value) -> dict[str, float]:
    out = {}
    for name, c in dict(value).items():
        c = float(c)
        if not math.isfinite(c):
            raise ValueError(f"grid.coefficients[{name!r}] must be finite, got {c}")
        out[str(name)] = c
    return out
