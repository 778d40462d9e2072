"""The fast sampling path (mac.wrap, flat gathers, shared coordinates, component-first
backtraces) against the plain formulation it replaced (np.mod, 2-D fancy indexing, points
(..., 2), Python sums from 0): the same operations in the same order, so bit for bit, signed
zeros included (compared as int64 bit patterns): elementwise + - * /, floor, fmod, clip, min,
max and take only, each correctly rounded or exact and never fused, so on every machine
(tests/BIT_FOR_BIT.md's rule). The taichi kernels mirror the plain form."""
import numpy as np
import pytest

from refsim.models.grid_fluid import advection
from refsim.models.grid_fluid.advection import (BACKTRACES, INTERPOLANTS, advect_cells,
                                                advect_faces)
from refsim.models.grid_fluid.mac import GHOST, LOCATIONS, MacGrid, padded, wrap


def bits(a):
    return np.ascontiguousarray(a, float).view(np.int64)


# -- the plain formulation ---------------------------------------------------------------------
def plain_coordinates(points, location, grid):
    out = []
    for axis, n in enumerate(grid.cells):
        st = LOCATIONS[location][axis]
        q = points[..., axis] / grid.h - (0.0 if st else 0.5)
        if grid.periodic[axis]:
            q = np.mod(q, n)
        else:
            low = 0.0 if st else -0.5
            q = np.clip(q, low, low + n)
        out.append(q + GHOST)
    return out


def plain_bilinear(pad, qx, qy):
    i = np.clip(np.floor(qx).astype(np.intp), 0, pad.shape[0] - 2)
    j = np.clip(np.floor(qy).astype(np.intp), 0, pad.shape[1] - 2)
    tx, ty = qx - i, qy - j
    return ((1 - tx) * ((1 - ty) * pad[i, j] + ty * pad[i, j + 1])
            + tx * ((1 - ty) * pad[i + 1, j] + ty * pad[i + 1, j + 1]))


def plain_weights(t):
    t2, t3 = t * t, t * t * t
    return (0.5 * (-t3 + 2 * t2 - t), 0.5 * (3 * t3 - 5 * t2 + 2),
            0.5 * (-3 * t3 + 4 * t2 + t), 0.5 * (t3 - t2))


def plain_cubic(pad, qx, qy, clamped):
    i = np.clip(np.floor(qx).astype(np.intp), 1, pad.shape[0] - 3)
    j = np.clip(np.floor(qy).astype(np.intp), 1, pad.shape[1] - 3)
    wx, wy = plain_weights(qx - i), plain_weights(qy - j)
    out = 0.0
    for a, wa in enumerate(wx):
        out = out + wa * sum(wb * pad[i + a - 1, j + b - 1] for b, wb in enumerate(wy))
    if clamped:
        near = np.stack([pad[i, j], pad[i + 1, j], pad[i, j + 1], pad[i + 1, j + 1]])
        out = np.clip(out, near.min(axis=0), near.max(axis=0))
    return out


def plain_at(a, location, points, grid, interpolant, wall="noslip"):
    pad = padded(a, location, grid, wall)
    qx, qy = plain_coordinates(points, location, grid)
    if interpolant == "linear":
        return plain_bilinear(pad, qx, qy)
    return plain_cubic(pad, qx, qy, interpolant == "cubic_clamped")


def plain_backtrace(points, velocity, dt, stepper):
    k1 = velocity(points)
    if stepper == "euler":
        return points - dt * k1
    if stepper == "rk2":
        return points - dt * velocity(points - 0.5 * dt * k1)
    k2 = velocity(points - 0.5 * dt * k1)
    k3 = velocity(points - 0.75 * dt * k2)
    return points - dt * ((2.0 / 9.0) * k1 + (1.0 / 3.0) * k2 + (4.0 / 9.0) * k3)


def plain_velocity(u, v, grid):
    return lambda p: np.stack([plain_at(u, "u", p, grid, "linear"),
                               plain_at(v, "v", p, grid, "linear")], axis=-1)


def flushes_subnormals() -> bool:
    """Whether this process flushes subnormal results to zero (x86 FTZ/DAZ: taichi's ti.init
    turns them on for the process, so a pytest worker that ran a taichi test first does; numpy
    and the in-house model then see 5e-324 as 0 in arithmetic, np.mod and wrap differently)."""
    return float((np.array([5e-324]) * 1.0)[0]) == 0.0


# -- the tests ---------------------------------------------------------------------------------
def test_wrap_equals_numpys_mod_bit_for_bit():
    rng = np.random.default_rng(0)
    for n in (1, 3, 7, 64, 100, 256):
        m = np.arange(-6.0, 7.0) * n
        # -5e-324 / n underflows to -0: floor 0, q - 0 < 0, the only case that needs the + n
        tiny = np.array([0.0, -0.0, 5e-324, -5e-324, 1e-300, -1e-300, 1e-20, -1e-20, 2e-16,
                         -2e-16, 0.3, -0.3])
        q = np.concatenate([
            (m[:, None] + tiny).ravel(),
            np.nextafter(m, np.inf), np.nextafter(m, -np.inf),  # q / n rounding to m
            rng.uniform(-5 * n, 5 * n, 4000), rng.uniform(-1, 1, 1000) * 1e-12])
        if flushes_subnormals():  # taichi's ti.init sets FTZ/DAZ for the whole process (a
            # worker that ran a taichi test first): wrap's arithmetic then flushes the
            # subnormal inputs (+-5e-324, nextafter(0)) to 0, np.mod's fmod does not
            q = q[(q == 0) | (np.abs(q) >= np.finfo(float).tiny)]
        big = np.array([1e15 + 0.5, -1e15 - 0.5, 2.0 ** 52 + 2, -(2.0 ** 60), 1e300, -1e300])
        for part in (q, q[q >= 0], big, np.concatenate([q, big])):  # big ones: np.mod's path
            assert np.array_equal(bits(wrap(part, n)), bits(np.mod(part, n))), n
    special = np.array([np.inf, -np.inf, np.nan, 1.0])
    with np.errstate(invalid="ignore"):
        assert np.array_equal(wrap(special, 5), np.mod(special, 5), equal_nan=True)
    assert wrap(np.array([]), 4).shape == (0,)


# h = 1/8: x / h exact, so in the still (zero) block departure points sit on entries, t = 0
GRIDS = {"periodic": MacGrid(12, 10, 0.125, (True, True)),
         "walls_lid": MacGrid(11, 9, 0.125, (False, False), lid=0.7),
         "mixed": MacGrid(10, 12, 0.1, (True, False))}


def fields(grid, seed):
    """Random faces with a block of -0.0 (at t = 0 every Catmull-Rom product is -0.0: the
    zero signs of the sums are exercised) and one of zeros of random sign (the clamp's min and
    max of +-0 depend on their order), boundary faces as the solver keeps them."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((grid.nx + 1, grid.ny))
    v = rng.standard_normal((grid.nx, grid.ny + 1))
    for a in (u, v):
        a[: grid.nx // 2, : grid.ny // 2] = -0.0
        block = a[grid.nx // 2:, grid.ny // 2:]
        block[...] = rng.choice([0.0, -0.0], block.shape)
    for arr, axis in ((u, 0), (v, 1)):
        arr = np.moveaxis(arr, axis, 0)
        if grid.periodic[axis]:
            arr[-1] = arr[0]
        else:
            arr[0] = arr[-1] = 0.0
    return u, v


@pytest.mark.parametrize("block", [None, 25])  # 25 points: blocks of 2 rows, the last short
@pytest.mark.parametrize("sides", list(GRIDS))
@pytest.mark.parametrize("interpolant", list(INTERPOLANTS))
@pytest.mark.parametrize("stepper", list(BACKTRACES))
def test_advection_equals_the_plain_formulation_bit_for_bit(sides, interpolant, stepper, block,
                                                           monkeypatch):
    if block is not None:
        monkeypatch.setattr(advection, "BLOCK", block)
    grid = GRIDS[sides]
    u, v = fields(grid, 1)
    dt = 2.5 * grid.h / max(np.abs(u).max(), np.abs(v).max())  # CFL 2.5: across seams, walls
    got = advect_faces(u, v, grid, dt, interpolant, stepper)
    vel = plain_velocity(u, v, grid)
    want = []
    for a, loc, pts in ((u, "u", grid.u_points()), (v, "v", grid.v_points())):
        want.append(plain_at(a, loc, plain_backtrace(pts, vel, dt, stepper), grid,
                             interpolant))
    want[0][[0, -1]] = want[0][[0]] if grid.periodic[0] else 0.0
    want[1][:, [0, -1]] = want[1][:, [0]] if grid.periodic[1] else 0.0
    for g, w in zip(got, want):
        assert np.array_equal(bits(g), bits(w))
    q = np.random.default_rng(2).standard_normal(grid.cells)
    q[:3] = -0.0
    for wall in ("even", "noslip"):
        cells = advect_cells(q, u, v, grid, dt, interpolant, stepper, wall)
        dep = plain_backtrace(grid.cell_points(), vel, dt, stepper)
        assert np.array_equal(bits(cells), bits(plain_at(q, "cell", dep, grid, interpolant,
                                                         wall)))
