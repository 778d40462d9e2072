"""MAC-grid operators: divergence, gradient, face <-> cell averages, and fields sampled at
arbitrary points (bilinear here; the advection's interpolants use the same ghost layers).

Layout (refsim.models.grid_fluid): u (nx + 1, ny) at (i h, (j + 1/2) h), v (nx, ny + 1) at
((i + 1/2) h, j h), cell quantities (nx, ny) at ((i + 1/2) h, (j + 1/2) h). A periodic axis
stores its last face equal to its first.

Ghost layers (`padded`): every array is extended by GHOST = 2 entries on each side of each
axis, so that a 4-point (cubic) stencil never leaves it:
- periodic axis: the n distinct entries wrapped (a staggered axis drops its duplicate last
  face first);
- wall, staggered axis (the component normal to the wall, its wall faces on the array's
  ends): odd reflection about the end face, ghost[-k] = 2 a[0] - a[k] (a[0] = 0: the normal
  velocity changes sign through the wall);
- wall, centred axis (the wall half a cell outside the first entry): "noslip" reflects about
  the wall's value w, ghost[-1 - k] = 2 w - a[k] (the linear interpolant then gives w on the
  wall: the tangential velocity of the wall, 0 or the lid), "even" mirrors,
  ghost[-1 - k] = a[k] (zero normal gradient, for cell scalars).
Points are clamped into the domain [0, nx h] x [0, ny h] along wall axes and wrapped along
periodic ones before interpolation.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

GHOST = 2


@dataclass(frozen=True)
class MacGrid:
    """The geometry: nx x ny cells of side h, per axis periodic (True) or walls (False), and
    the tangential velocity of the top wall (lid)."""

    nx: int
    ny: int
    h: float
    periodic: tuple[bool, bool] = (False, False)
    lid: float = 0.0

    @classmethod
    def of(cls, part) -> "MacGrid":
        """From a `FluidGrid` scene part."""
        return cls(part.nx, part.ny, part.h, tuple(s == "periodic" for s in part.sides),
                   part.lid)

    @property
    def cells(self) -> tuple[int, int]:
        return (self.nx, self.ny)

    def u_points(self) -> np.ndarray:
        """(nx + 1, ny, 2) positions of the u faces."""
        return _points(np.arange(self.nx + 1) * self.h, (np.arange(self.ny) + 0.5) * self.h)

    def v_points(self) -> np.ndarray:
        """(nx, ny + 1, 2) positions of the v faces."""
        return _points((np.arange(self.nx) + 0.5) * self.h, np.arange(self.ny + 1) * self.h)

    def cell_points(self) -> np.ndarray:
        """(nx, ny, 2) cell centres."""
        return _points((np.arange(self.nx) + 0.5) * self.h, (np.arange(self.ny) + 0.5) * self.h)


def _points(x, y) -> np.ndarray:
    xx, yy = np.meshgrid(x, y, indexing="ij")
    return np.stack([xx, yy], axis=-1)


# -- operators ---------------------------------------------------------------------------------
def divergence(u, v, h) -> np.ndarray:
    """D u = (u[i+1, j] - u[i, j] + v[i, j+1] - v[i, j]) / h per cell, shape (nx, ny)."""
    return (np.diff(u, axis=0) + np.diff(v, axis=1)) / h


def gradient(p, grid: MacGrid) -> tuple[np.ndarray, np.ndarray]:
    """G p on the faces: (p[i] - p[i-1]) / h on interior faces, across the seam on a periodic
    axis (face 0 from p[nx-1] to p[0], the last face equal to the first), 0 on wall faces."""
    return _face_difference(p, 0, grid.periodic[0], grid.h), \
        _face_difference(p, 1, grid.periodic[1], grid.h)


def _face_difference(p, axis, periodic, h):
    n = p.shape[axis]
    shape = list(p.shape)
    shape[axis] = n + 1
    out = np.zeros(shape)
    inner = [slice(None)] * 2
    inner[axis] = slice(1, n)
    out[tuple(inner)] = np.diff(p, axis=axis) / h
    if periodic:
        seam = (np.take(p, 0, axis=axis) - np.take(p, n - 1, axis=axis)) / h
        first, last = [slice(None)] * 2, [slice(None)] * 2
        first[axis], last[axis] = 0, n
        out[tuple(first)] = seam
        out[tuple(last)] = seam
    return out


def faces_to_cells(u, v) -> tuple[np.ndarray, np.ndarray]:
    """The velocity at the cell centres: the mean of each cell's two faces per component."""
    return 0.5 * (u[1:] + u[:-1]), 0.5 * (v[:, 1:] + v[:, :-1])


def cells_to_faces(q, grid: MacGrid) -> tuple[np.ndarray, np.ndarray]:
    """A cell quantity at the faces: the mean of the two cells beside each face; across the
    seam on a periodic axis; on a wall face the one cell inside."""
    return _face_mean(q, 0, grid.periodic[0]), _face_mean(q, 1, grid.periodic[1])


def _face_mean(q, axis, periodic):
    first, last = np.take(q, [0], axis=axis), np.take(q, [-1], axis=axis)
    inner = 0.5 * (np.take(q, range(1, q.shape[axis]), axis=axis)
                   + np.take(q, range(q.shape[axis] - 1), axis=axis))
    if periodic:
        seam = 0.5 * (first + last)
        return np.concatenate([seam, inner, seam], axis=axis)
    return np.concatenate([first, inner, last], axis=axis)


def enforce_boundaries(u, v, grid: MacGrid) -> None:
    """In place: wall faces 0 (no through-flow), a periodic axis' last faces = its first."""
    for arr, axis in ((u, 0), (v, 1)):
        last = [slice(None)] * 2
        last[axis] = -1
        first = [slice(None)] * 2
        first[axis] = 0
        if grid.periodic[axis]:
            arr[tuple(last)] = arr[tuple(first)]
        else:
            arr[tuple(first)] = 0.0
            arr[tuple(last)] = 0.0


# -- ghost layers and sampling -----------------------------------------------------------------
LOCATIONS = {"u": (True, False), "v": (False, True), "cell": (False, False)}  # staggered per axis


def _pad_axis(a, axis, periodic, staggered, wall, low, high):
    n = a.shape[axis] - (1 if staggered else 0)
    take = lambda idx: np.take(a, idx, axis=axis)  # noqa: E731
    if periodic:
        core = take(np.arange(n))
        return np.concatenate([np.take(core, [n - 2, n - 1], axis=axis), core,
                               np.take(core, [0, 1], axis=axis)], axis=axis)
    if staggered:  # odd about the end faces
        return np.concatenate([2 * take([0]) - take([2, 1]), a,
                               2 * take([n]) - take([n - 1, n - 2])], axis=axis)
    if wall == "even":
        return np.concatenate([take([1, 0]), a, take([n - 1, n - 2])], axis=axis)
    return np.concatenate([2 * low - take([1, 0]), a, 2 * high - take([n - 1, n - 2])],
                          axis=axis)


def wall_values(location: str, grid: MacGrid) -> tuple[tuple[float, float], tuple[float, float]]:
    """(low, high) wall value per axis of a no-slip ghost: u's at y = 0 is 0 and at the top the
    lid's speed; every other tangential wall value is 0."""
    return ((0.0, 0.0), (0.0, grid.lid if location == "u" else 0.0))


def padded(a, location: str, grid: MacGrid, wall: str = "noslip") -> np.ndarray:
    """`a` (of `location` "u", "v" or "cell") with GHOST ghost entries per side and axis."""
    staggered = LOCATIONS[location]
    values = wall_values(location, grid)
    out = np.asarray(a, float)
    for axis in (0, 1):
        out = _pad_axis(out, axis, grid.periodic[axis], staggered[axis], wall, *values[axis])
    return out


def wrap(q, n: int) -> np.ndarray:
    """np.mod(q, n) for a positive integer n, bit for bit, in a sixth of its time (numpy's float
    mod is an fmod and a sign fix, ~50 additions' cost): r = q - n floor(q / n), then r + n where
    r < 0. Why equal: n floor(q / n) is exact (|n floor(q / n)| < 2^52, checked, else np.mod).
    With k the true floor, e = q - k n is fmod's exact value when q >= 0; for q < 0 numpy rounds
    fmod + n, i.e. e, once, as q - k n does. The rounded q / n never crosses an integer m != 0
    (the spacing of doubles at m n, over n, exceeds half the spacing at m); it reaches -0 from
    a subnormal q < 0: then r = q < 0 and the + n is numpy's own (fmod = q, + n). -0 gives +0
    as numpy's; NaN and inf go to np.mod. The taichi kernel wraps the same way."""
    q = np.asarray(q, float)
    if q.size == 0:
        return np.mod(q, n)
    k = np.floor(q / n)
    if not (-2.0 ** 52 < k.min() * n and k.max() * n < 2.0 ** 52):  # also NaN, inf
        return np.mod(q, n)
    r = np.subtract(q, np.multiply(k, n, out=k), out=k)
    if r.min() < 0.0:
        np.add(r, n, out=r, where=r < 0.0)
    return r


def axis_coordinate(scaled, n: int, periodic: bool, staggered: bool) -> np.ndarray:
    """A fractional index into a padded axis from x / h: minus 1/2 on a centred axis, wrapped
    (periodic) or clamped into the domain (walls), plus GHOST. A new array (`scaled` kept)."""
    q = scaled if staggered else scaled - 0.5  # x / h - 0.0 is x / h, bit for bit
    if periodic:
        q = wrap(q, n)
    else:
        low = 0.0 if staggered else -0.5
        q = np.clip(q, low, low + n)
    return np.add(q, GHOST, out=q)


def coordinates(sx, sy, location: str, grid: MacGrid) -> tuple[np.ndarray, np.ndarray]:
    """Fractional indices into the padded array of `location` of points given as x / h and
    y / h (broadcastable arrays): `index_coordinates` without its divisions."""
    staggered = LOCATIONS[location]
    return (axis_coordinate(sx, grid.nx, grid.periodic[0], staggered[0]),
            axis_coordinate(sy, grid.ny, grid.periodic[1], staggered[1]))


def index_coordinates(points, location: str, grid: MacGrid) -> tuple[np.ndarray, np.ndarray]:
    """Fractional indices into the padded array of `location` of points (..., 2): wrapped on
    periodic axes, clamped into the domain on wall axes."""
    return coordinates(points[..., 0] / grid.h, points[..., 1] / grid.h, location, grid)


def stencil(shape, qx, qy, low: int, margin: int, own: bool = False):
    """(k, tx, ty): the flat index of entry (i, j) of a C-ordered array of `shape`, i = floor(qx)
    clamped to [low, shape[0] - margin] (j alike), and the fractions qx - i, qy - j (into qx, qy
    where `own`). Clamped as floats before the cast: the same i, j as clipping the cast floors,
    for every finite q. Broadcastable qx, qy."""
    fx, fy = np.floor(qx), np.floor(qy)
    np.clip(fx, low, shape[0] - margin, out=fx)
    np.clip(fy, low, shape[1] - margin, out=fy)
    tx = np.subtract(qx, fx, out=qx if own else None)
    ty = np.subtract(qy, fy, out=qy if own else None)
    fx *= shape[1]
    if fx.shape == np.broadcast_shapes(fx.shape, fy.shape):
        fx += fy
    else:
        fx = fx + fy
    return fx.astype(np.intp), tx, ty  # exact: indices < 2^53


def gather(flat, k, offset: int, out=None) -> np.ndarray:
    """flat[k + offset] (a flat take: ~5x cheaper than 2-D fancy indexing); 'clip' only keeps a
    NaN coordinate's garbage index inside (its value is NaN through its fraction anyway)."""
    return np.take(flat[offset:], k, out=out, mode="clip")


def bilinear(pad, qx, qy, own: bool = False) -> np.ndarray:
    """The bilinear interpolant of a padded array at fractional indices (qx, qy) (overwritten
    where `own`): (1 - tx) ((1 - ty) p00 + ty p01) + tx ((1 - ty) p10 + ty p11), in place on
    the gathered values (products commute bit for bit; the sums keep their order)."""
    pad = np.ascontiguousarray(pad)
    k, tx, ty = stencil(pad.shape, qx, qy, 0, 2, own)
    flat, s = pad.reshape(-1), pad.shape[1]
    a, b, c, d = (gather(flat, k, o) for o in (0, 1, s, s + 1))
    b *= ty
    d *= ty
    sy = np.subtract(1, ty, out=ty)
    a *= sy
    a += b
    c *= sy
    c += d
    c *= tx
    a *= np.subtract(1, tx, out=tx)
    a += c
    return a


def sample(a, location: str, points, grid: MacGrid, wall: str = "noslip") -> np.ndarray:
    """`a` (of `location`) bilinearly interpolated at points (..., 2)."""
    return bilinear(padded(a, location, grid, wall), *index_coordinates(points, location, grid))


def velocity_at(u, v, points, grid: MacGrid) -> np.ndarray:
    """(..., 2) the velocity at points (..., 2) by bilinear interpolation of each face array
    (no-slip ghosts at walls, the lid's speed at the top)."""
    return np.stack([sample(u, "u", points, grid), sample(v, "v", points, grid)], axis=-1)


class PaddedVelocity:
    """(x / h, y / h) -> (u, v) there, bilinear, from the padded faces pu, pv built once (no-slip
    ghosts and the lid, or free-slip `wall` "even" ones): the divisions shared by the two
    components; broadcastable arrays."""

    def __init__(self, u, v, grid: MacGrid, wall: str = "noslip"):
        self.grid = grid
        self.pu, self.pv = padded(u, "u", grid, wall), padded(v, "v", grid, wall)

    def __call__(self, sx, sy) -> tuple[np.ndarray, np.ndarray]:
        return (bilinear(self.pu, *coordinates(sx, sy, "u", self.grid), own=True),
                bilinear(self.pv, *coordinates(sx, sy, "v", self.grid), own=True))


def velocity_sampler(u, v, grid: MacGrid, wall: str = "noslip"):
    """points -> velocity_at(u, v, points) with the ghost layers built once (for the several
    evaluations of one backtrace); `wall` "noslip" (the tangential velocity odd about a wall,
    the wall's value there) or "even" (mirrored: free slip, no shear at the wall)."""
    at = PaddedVelocity(u, v, grid, wall)
    return lambda points: np.stack(at(points[..., 0] / grid.h, points[..., 1] / grid.h),
                                   axis=-1)


def stack_faces(u, v) -> np.ndarray:
    """Every face value of a batch of fields: u (b, nx + 1, ny) and v (b, nx, ny + 1) as one
    (b, faces) array, u faces first (C order), as the cases compare them."""
    return np.concatenate([np.reshape(u, (len(u), -1)), np.reshape(v, (len(v), -1))], 1)
