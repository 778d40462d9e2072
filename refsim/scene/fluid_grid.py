"""An incompressible fluid on a staggered (MAC) grid: the `FluidGrid` part (kind "fluid_grids").

Conventions (refsim.models.grid_fluid states them in full): nx x ny square cells of side h on
[0, nx h] x [0, ny h], arrays indexed [i, j] with i along x, j along y, float64;
u[i, j] (x-velocity) on the vertical faces at (i h, (j + 1/2) h), shape (nx + 1, ny);
v[i, j] on the horizontal faces at ((i + 1/2) h, j h), shape (nx, ny + 1); the pressure and
other cell quantities p[i, j] at ((i + 1/2) h, (j + 1/2) h), shape (nx, ny).

Sides per axis (x, then y): "wall" (no through-flow and no slip: the normal face velocity is 0
on the wall, the tangential velocity of the wall is 0, except the top wall's `lid`) or
"periodic" (the last face equals the first: u[nx] == u[0] along a periodic x, v[:, ny] ==
v[:, 0] along a periodic y, checked here and kept so by every step).
Fields: `nu` the kinematic viscosity (m^2/s, >= 0), `density` (kg/m^3, > 0; the observed
pressure is kinematic, p / density), `lid` the top wall's tangential velocity (m/s; needs
walls along y), `gravity`: whether the scene's gravity (its x and y components, 2D y-up) acts
on the fluid (a body force; off by default), `marks`: optional cell marks (int8, (nx, ny)):
FLUID, AIR (free surface: p = 0 there) or SOLID (every face of a solid cell held at 0), None
for all fluid; `rtol`: the relative residual target of every pressure projection (in (0, 1));
`viscosity_scheme`: "implicit" (backward Euler, a sparse solve) or "explicit" (forward Euler).

Observables (refsim/observation.py, part "fluid_grids"): "grid.u" (nx + 1, ny) m/s and
"grid.v" (nx, ny + 1) m/s, the face velocities; "grid.p" (nx, ny) Pa / (kg/m^3) = m^2/s^2, the
kinematic pressure of the last projection (0 before any step); engines may add
"divergence" (the max |D u| over fluid cells, 1/s) and the projection's "residual" and
"iterations".
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._validate import ArrayPart, _nonnegative, _positive, _set, choice, float_array, read_only

SIDES = ("wall", "periodic")
VISCOSITY_SCHEMES = ("implicit", "explicit")
FLUID, AIR, SOLID = 0, 1, 2  # cell marks
MIN_CELLS = 2


def _cells(name: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < MIN_CELLS:
        raise ValueError(f"fluid_grid.{name} must be an integer >= {MIN_CELLS}, got {value!r}")
    return int(value)


def _sides(value) -> tuple[str, str]:
    items = (value, value) if isinstance(value, str) else tuple(value)
    if len(items) != 2:
        raise ValueError(f"fluid_grid.sides must be one kind or one per axis (x, y), got "
                         f"{value!r}")
    for axis, kind in enumerate(items):
        choice(f"fluid_grid.sides[{axis}]", kind, SIDES)
    return tuple(items)


def _marks(value, shape):
    if value is None:
        return None
    arr = np.array(value)
    if arr.shape != shape or not np.all(np.isin(arr, (FLUID, AIR, SOLID))):
        raise ValueError(f"fluid_grid.marks must be an array of shape {shape} of FLUID (0), "
                         f"AIR (1) or SOLID (2), got shape {arr.shape}")
    return read_only(arr.astype(np.int8))


@dataclass(frozen=True, eq=False)
class FluidGrid(ArrayPart):
    """nx, ny cells (integers >= 2) of side h (m, > 0); sides per axis in SIDES; u (nx + 1, ny)
    and v (nx, ny + 1) the initial face velocities (m/s, finite, zero on wall faces, equal on
    a periodic axis' first and last faces); nu (m^2/s, >= 0); density (kg/m^3, > 0); lid (m/s,
    finite, the top wall's tangential velocity, walls along y); gravity (bool); marks (None or
    (nx, ny) of FLUID/AIR/SOLID); rtol in (0, 1); viscosity_scheme in VISCOSITY_SCHEMES."""

    nx: int
    ny: int
    h: float
    u: np.ndarray
    v: np.ndarray
    sides: tuple | str = "wall"
    nu: float = 0.0
    density: float = 1.0
    lid: float = 0.0
    gravity: bool = False
    marks: np.ndarray | None = None
    rtol: float = 1e-10
    viscosity_scheme: str = "implicit"

    kind = "fluid_grids"

    def __post_init__(self):
        nx, ny = _cells("nx", self.nx), _cells("ny", self.ny)
        _set(self, "nx", nx)
        _set(self, "ny", ny)
        _set(self, "h", _positive("fluid_grid.h", self.h))
        _set(self, "sides", _sides(self.sides))
        _set(self, "nu", _nonnegative("fluid_grid.nu", self.nu))
        _set(self, "density", _positive("fluid_grid.density", self.density))
        lid = float(self.lid)
        if not math.isfinite(lid):
            raise ValueError(f"fluid_grid.lid must be finite, got {lid}")
        if lid != 0.0 and self.sides[1] != "wall":
            raise ValueError("fluid_grid.lid must be 0 unless sides[1] (y) is 'wall', got "
                             f"{lid} with sides {self.sides}")
        _set(self, "lid", lid)
        if not isinstance(self.gravity, (bool, np.bool_)):
            raise ValueError(f"fluid_grid.gravity must be True or False, got {self.gravity!r}")
        _set(self, "gravity", bool(self.gravity))
        rtol = float(self.rtol)
        if not 0.0 < rtol < 1.0:
            raise ValueError(f"fluid_grid.rtol must be in (0, 1), got {rtol}")
        _set(self, "rtol", rtol)
        choice("fluid_grid.viscosity_scheme", self.viscosity_scheme, VISCOSITY_SCHEMES)
        _set(self, "marks", _marks(self.marks, (nx, ny)))
        _set(self, "u", self._faces("u", self.u, (nx + 1, ny), 0))
        _set(self, "v", self._faces("v", self.v, (nx, ny + 1), 1))

    def _faces(self, name, value, shape, axis):
        arr = float_array(f"fluid_grid.{name}", value, shape)
        first, last = np.take(arr, 0, axis=axis), np.take(arr, -1, axis=axis)
        if self.sides[axis] == "periodic" and not np.array_equal(first, last):
            raise ValueError(f"fluid_grid.{name} must have its last faces equal to its first "
                             f"along the periodic axis {axis}")
        if self.sides[axis] == "wall" and (np.any(first != 0) or np.any(last != 0)):
            raise ValueError(f"fluid_grid.{name} must be 0 on the wall faces of axis {axis} "
                             "(no through-flow)")
        return arr

    @property
    def shape(self) -> tuple[int, int]:
        """(nx, ny): the cells."""
        return (self.nx, self.ny)

    def features(self) -> set[str]:
        out = {"fluid_grid"}
        if self.nu > 0:
            out.add("viscosity")
        if self.marks is not None and np.any(self.marks == AIR):
            out.add("free_surface")
        if self.marks is not None and np.any(self.marks == SOLID):
            out.add("solid_cells")
        return out
