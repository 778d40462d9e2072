"""refsim's MAC face arrays <-> a PhiFlow `StaggeredGrid` (phiflow 3.4.0, phiml 1.16.1).

refsim's layout (refsim.models.grid_fluid): u[i, j] on the vertical faces at (i h, (j + 1/2) h),
shape (nx + 1, ny); v[i, j] on the horizontal faces at ((i + 1/2) h, j h), shape (nx, ny + 1);
indices [i, j] with i along x ('ij').

PhiFlow stores a staggered vector field as a stack over the dual dimension '~vector' of one
tensor per component, each with spatial dimensions (x, y) in that order (read here with
`.numpy('x,y')`, so [i, j] with i along x as in refsim), and only the faces its boundary does
not fix (checked by sampling u = 10 x + y on a 4 x 4 grid):
- a wall axis (a constant extrapolation, ZERO or the lid's value): the normal component keeps
  the interior faces only, x-faces i = 1 .. nx - 1, shape (nx - 1, ny): refsim's u[1:-1]; the
  wall faces u[0] and u[nx] are the boundary's (0, no through-flow) and are put back as 0;
- a periodic axis: the faces i = 0 .. nx - 1, shape (nx, ny): refsim's u[:-1]; refsim's last
  face u[nx] is the periodic copy of u[0] and is put back as that copy.
The same along y for v. The tangential components keep all their rows (ny for u).
"""
from __future__ import annotations

import numpy as np


def trim(u: np.ndarray, v: np.ndarray, periodic: tuple[bool, bool]):
    """(u, v) in refsim's layout -> the face arrays PhiFlow stores (module doc)."""
    cut = lambda a, axis, p: np.take(a, np.arange(a.shape[axis] - 1) if p  # noqa: E731
                                     else np.arange(1, a.shape[axis] - 1), axis=axis)
    return cut(np.asarray(u, float), 0, periodic[0]), cut(np.asarray(v, float), 1, periodic[1])


def pad(u: np.ndarray, v: np.ndarray, periodic: tuple[bool, bool]):
    """PhiFlow's face arrays -> refsim's (nx + 1, ny) and (nx, ny + 1): the wall faces 0, the
    periodic last face a copy of the first (module doc)."""
    def full(a, axis, p):
        if p:
            return np.concatenate([a, np.take(a, [0], axis=axis)], axis=axis)
        shape = list(a.shape)
        shape[axis] = 1
        zero = np.zeros(shape)
        return np.concatenate([zero, a, zero], axis=axis)
    return full(np.asarray(u, float), 0, periodic[0]), full(np.asarray(v, float), 1, periodic[1])


def divergence(u: np.ndarray, v: np.ndarray, h: float) -> np.ndarray:
    """refsim's discrete divergence per cell, (u[i+1,j] - u[i,j] + v[i,j+1] - v[i,j]) / h."""
    return (u[1:] - u[:-1] + v[:, 1:] - v[:, :-1]) / h


def boundary(part):
    """The PhiFlow velocity boundary of a FluidGrid: PERIODIC on a periodic axis; on a wall
    axis the constant 0 (ZERO: no through-flow and no slip), the top wall (y+) the lid's
    velocity vec(x=lid, y=0) (PhiFlow's per-side dict, as its lid-driven cavity example
    writes it: {'x': 0, 'y-': 0, 'y+': vec(x=1, y=0)})."""
    from phi.flow import extrapolation, vec
    periodic = tuple(s == "periodic" for s in part.sides)
    if all(periodic):
        return extrapolation.PERIODIC
    out = {"x": extrapolation.PERIODIC if periodic[0] else 0}
    if periodic[1]:
        out["y"] = extrapolation.PERIODIC
    else:
        out["y-"] = 0
        out["y+"] = vec(x=float(part.lid), y=0.0) if part.lid else 0
    return out


def to_grid(u, v, part, ext):
    """A float64 StaggeredGrid on [0, nx h] x [0, ny h] holding refsim's (u, v) (call inside
    `phi.math.precision(64)`)."""
    from phi import math as pm
    from phi.flow import Box, StaggeredGrid
    periodic = tuple(s == "periodic" for s in part.sides)
    pu, pv = trim(u, v, periodic)
    values = pm.stack({"x": pm.tensor(pu, pm.spatial("x,y")),
                       "y": pm.tensor(pv, pm.spatial("x,y"))}, pm.dual(vector="x,y"))
    return StaggeredGrid(values, ext, x=part.nx, y=part.ny,
                         bounds=Box(x=part.nx * part.h, y=part.ny * part.h))


def from_grid(grid, part):
    """refsim's (u, v) face arrays (float64) of a StaggeredGrid built by `to_grid`."""
    periodic = tuple(s == "periodic" for s in part.sides)
    values = grid.values
    pu = values[{"~vector": "x"}].numpy("x,y")
    pv = values[{"~vector": "y"}].numpy("x,y")
    return pad(pu, pv, periodic)
