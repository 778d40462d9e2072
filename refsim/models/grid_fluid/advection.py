"""Semi-Lagrangian advection on the MAC grid (slide 001): each face (or cell) value at time
n + 1 is the field at time n interpolated at the departure point of the characteristic that
ends on it, x_d = x - int_0^dt u dt' traced backwards through the frozen velocity u^n.

Backtrace steppers (`BACKTRACES`, explicit Runge-Kutta on x' = -u(x), velocity sampled by
bilinear interpolation, refsim.models.grid_fluid.mac):
- "euler": x_d = x - dt u(x) (order 1);
- "rk2": the explicit midpoint rule, x_d = x - dt u(x - dt/2 u(x)) (order 2);
- "rk3": Ralston's third-order method, k1 = u(x), k2 = u(x - dt/2 k1), k3 = u(x - 3 dt/4 k2),
  x_d = x - dt (2 k1 + 3 k2 + 4 k3) / 9 (order 3; Ralston 1962, the minimum error bound
  third-order tableau).
Interpolants (`INTERPOLANTS`) of the advected field at x_d:
- "linear": bilinear, the tensor product of the hat (exact for bilinear fields; error
  O(h^2), dissipative: a mode's amplitude falls by ~ alpha (1 - alpha) (k h)^2 / 2 a step,
  alpha the fractional CFL);
- "cubic": Catmull-Rom cubic per axis (the Hermite cubic with central-difference slopes;
  exact for quadratics, error O(h^3); its amplitude loss per step ~ (k h)^4);
- "cubic_clamped": the Catmull-Rom value clamped to the range of the 2 x 2 nearest entries
  (monotone: no new extrema; Fedkiw, Stam & Jensen 2001 and Bridson 2015 clamp the same way).
  At a smooth extremum the field exceeds its nearest values by ~ f'' h^2 / 8, which the clamp
  cuts off: O(h^2) in the max norm (measured 2.07 against 3.12 for the plain cubic), O(h^3)
  away from extrema.
A time-stepping error O(dt^q) of the backtrace and an interpolation error O(h^(p+1)) each
step give a global error O(dt^q + h^(p+1) / dt) (p + 1 = 2 linear, 3 cubic): at a fixed h,
shrinking dt raises the interpolation's share (more interpolations per unit time).

Implementation (advect_faces / advect_cells): by blocks of rows (BLOCK points), points component
first (2, ...), x / h shared by the two velocity components, the first stage on the 1-D axes,
flat gathers, in-place arithmetic on the functions' own temporaries, mac.wrap for np.mod: the
plain formulas' operations in their order, bit for bit (tests/models/test_grid_fluid_sampling.py;
the taichi kernels do the same), ~4x faster (issue 27: level with taichi's CPU kernels, one
thread each).
"""
from __future__ import annotations

import numpy as np

from refsim.integrators.semi_lagrangian import BACKTRACES, INTERPOLANTS  # names and orders

from .mac import (LOCATIONS, MacGrid, PaddedVelocity, bilinear, coordinates, enforce_boundaries,
                  gather, index_coordinates, padded, stencil)

BACKTRACE_TEXT = {"euler": "explicit Euler", "rk2": "explicit midpoint (RK2)",
                  "rk3": "Ralston's third-order RK (2/9, 1/3, 4/9)"}
INTERPOLANT_TEXT = {"linear": "bilinear (hat per axis)",
                    "cubic": "Catmull-Rom cubic per axis (tensor product, 16 points)",
                    "cubic_clamped": "Catmull-Rom cubic clamped to the 2 x 2 nearest values "
                                     "(monotone)"}


def check(interpolant: str, backtrace: str) -> None:
    if interpolant not in INTERPOLANTS:
        raise ValueError(f"advection interpolant must be one of {list(INTERPOLANTS)}, got "
                         f"{interpolant!r}")
    if backtrace not in BACKTRACES:
        raise ValueError(f"advection backtrace must be one of {list(BACKTRACES)}, got "
                         f"{backtrace!r}")


def backtrace(points, velocity, dt, stepper: str, k1=None) -> np.ndarray:
    """Departure points of characteristics ending at `points` after dt, through the frozen
    field `velocity(points)` of the points' layout ((..., 2), or (2, ...) component first);
    `k1`: velocity(points) where already known. Euler points - dt k1; rk2
    points - dt k(points - (dt / 2) k1); rk3 k2 = k(points - (dt / 2) k1),
    k3 = k(points - (3 dt / 4) k2), points - dt ((2/9 k1 + 1/3 k2) + 4/9 k3): each product and
    sum rounded in that order, in place on this function's own temporaries."""
    if stepper not in BACKTRACES:
        raise ValueError(f"advection backtrace must be one of {list(BACKTRACES)}, got "
                         f"{stepper!r}")
    k1 = velocity(points) if k1 is None else k1
    if stepper == "euler":
        return _minus(points, dt * k1)
    k2 = velocity(_minus(points, 0.5 * dt * k1))
    if stepper == "rk2":
        return _minus(points, dt * k2)
    k3 = velocity(_minus(points, 0.75 * dt * k2))
    mean = (2.0 / 9.0) * k1
    mean += (1.0 / 3.0) * k2
    mean += (4.0 / 9.0) * k3
    mean *= dt
    return _minus(points, mean)


def _minus(points, step):
    """points - step, into `step` (a temporary of the caller's) where it has the result's shape
    and type."""
    if isinstance(step, np.ndarray) and step.shape == np.broadcast_shapes(
            np.shape(points), step.shape) and step.dtype == np.result_type(points, step):
        return np.subtract(points, step, out=step)
    return points - step


def catmull_rom_weights(t) -> tuple:
    """The four Catmull-Rom weights of entries -1, 0, 1, 2 at fraction t in [0, 1]:
    0.5 (-t^3 + 2 t^2 - t), 0.5 (3 t^3 - 5 t^2 + 2), 0.5 (-3 t^3 + 4 t^2 + t), 0.5 (t^3 - t^2),
    each rounded in that order (-a + b is b - a and (-3) t^3 is -(3 t^3), bit for bit)."""
    t2 = t * t
    t3 = t2 * t  # t * t * t
    t3x3 = 3 * t3
    w0 = 2 * t2
    w0 -= t3
    w0 -= t
    w0 *= 0.5
    w1 = -5 * t2
    w1 += t3x3
    w1 += 2
    w1 *= 0.5
    w2 = 4 * t2
    w2 -= t3x3
    w2 += t
    w2 *= 0.5
    t3 -= t2
    t3 *= 0.5
    return w0, w1, w2, t3


def cubic(pad, qx, qy, clamped=False, own: bool = False) -> np.ndarray:
    """The Catmull-Rom tensor-product interpolant of a padded array at (qx, qy) (overwritten
    where `own`); `clamped` limits it to the range of the 2 x 2 nearest entries. Sums:
    sum_a wx_a sum_b wy_b p_ab in the order a, b = 0..3; the final + 0.0 gives a zero's sign as
    sums started from 0 would; min and max over (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)
    in that order (a zero's sign)."""
    pad = np.ascontiguousarray(pad)
    k, tx, ty = stencil(pad.shape, qx, qy, 1, 3, own)
    wx, wy = catmull_rom_weights(tx), catmull_rom_weights(ty)
    flat, s = pad.reshape(-1), pad.shape[1]
    k -= s + 1  # entry (i - 1, j - 1): entry (i + a - 1, j + b - 1) is k + a s + b
    p = [np.empty(k.shape) for _ in range(4)]
    out = near = None
    for a, wa in enumerate(wx):
        for b in range(4):
            gather(flat, k, a * s + b, out=p[b])
        if clamped and a == 1:
            near = p[1].copy(), p[2].copy()
        elif clamped and a == 2:
            bounds = [f(f(f(near[0], p[1]), near[1]), p[2]) for f in (np.minimum, np.maximum)]
        row = p[0]
        row *= wy[0]
        for b in (1, 2, 3):
            p[b] *= wy[b]
            row += p[b]
        row *= wa
        if out is None:
            out, p[0] = row, np.empty(k.shape)
        else:
            out += row
    out += 0.0
    if clamped:
        np.clip(out, *bounds, out=out)
    return out


def interpolate(pad, qx, qy, interpolant: str, own: bool = False) -> np.ndarray:
    """`interpolant` of the padded array at (qx, qy) (overwritten where `own`)."""
    if interpolant == "linear":
        return bilinear(pad, qx, qy, own)
    return cubic(pad, qx, qy, interpolant == "cubic_clamped", own)


def interpolate_at(a, location, points, grid: MacGrid, interpolant: str,
                   wall: str = "noslip") -> np.ndarray:
    """`a` (of `location`: "u", "v" or "cell") at points (..., 2) by `interpolant`."""
    return interpolate(padded(a, location, grid, wall),
                       *index_coordinates(points, location, grid), interpolant, own=True)


def _axes(location: str, grid: MacGrid):
    """The 1-D x and y of `location`'s entries (grid.u_points() etc. per axis)."""
    return [np.arange(n + 1) * grid.h if s else (np.arange(n) + 0.5) * grid.h
            for n, s in zip(grid.cells, LOCATIONS[location])]


# Points per block of rows: a block's ~20 temporaries (117 KB each, under glibc's initial
# 128 KB mmap threshold) stay in cache and in malloc's heap. Whole-grid temporaries of 0.5-2 MB
# were fresh pages each time (512^2 rk3-cubic: 51 000 page faults a step, 40 % of its time;
# blocks of 8k-16k points: none, the step 2.4x faster). Every point's arithmetic is its own:
# blocks change no value.
BLOCK = 15000


def _advect(pad, location, velocity, grid: MacGrid, dt, interpolant, stepper):
    """The padded array `pad` of `location` at its entries' departure points, by blocks of
    rows. Points are component first (2, ...); k1 from the 1-D axes (broadcast: the same
    values, fewer operations)."""
    x, y = _axes(location, grid)
    out = np.empty((len(x), len(y)))
    rows = max(1, BLOCK // len(y))

    def at(p):
        return np.stack(velocity(p[0] / grid.h, p[1] / grid.h))
    for r in range(0, len(x), rows):
        xr = x[r:r + rows, None]
        k1 = np.stack(np.broadcast_arrays(*velocity(xr / grid.h, y[None, :] / grid.h)))
        points = np.stack(np.broadcast_arrays(xr, y[None, :]))
        departure = backtrace(points, at, dt, stepper, k1)
        out[r:r + rows] = interpolate(pad, *coordinates(departure[0] / grid.h,
                                                        departure[1] / grid.h, location, grid),
                                      interpolant, own=True)
    return out


def advect_faces(u, v, grid: MacGrid, dt, interpolant="linear", stepper="rk2"):
    """(u, v) advected by themselves over dt: every face value taken at its departure point
    (traced through the bilinear velocity of u^n, v^n); wall faces 0, periodic copies kept."""
    check(interpolant, stepper)
    velocity = PaddedVelocity(u, v, grid)  # its ghosts are the interpolated arrays' own
    out = [_advect(pad, loc, velocity, grid, dt, interpolant, stepper)
           for pad, loc in ((velocity.pu, "u"), (velocity.pv, "v"))]
    enforce_boundaries(out[0], out[1], grid)
    return out[0], out[1]


def advect_cells(q, u, v, grid: MacGrid, dt, interpolant="linear", stepper="rk2",
                 wall: str = "even") -> np.ndarray:
    """A cell quantity q (nx, ny) advected by the face velocity (u, v) over dt; "even" walls
    (zero normal gradient) unless told."""
    check(interpolant, stepper)
    return _advect(padded(q, "cell", grid, wall), "cell", PaddedVelocity(u, v, grid), grid,
                   dt, interpolant, stepper)


def describe(interpolant: str, stepper: str) -> dict:
    return {"interpolant": interpolant, "interpolant_text": INTERPOLANT_TEXT[interpolant],
            "interpolant_order_h": INTERPOLANTS[interpolant], "backtrace": stepper,
            "backtrace_text": BACKTRACE_TEXT[stepper], "backtrace_order_dt":
            BACKTRACES[stepper], "backtrace_velocity": "bilinear from u^n, v^n (frozen)",
            "ghosts": "no-slip (odd about the wall's velocity) tangential, odd normal; "
                      "periodic wrap", "departure_points": "clamped into the domain at walls"}


__all__ = ["BACKTRACES", "INTERPOLANTS", "LOCATIONS", "advect_cells", "advect_faces",
           "backtrace", "cubic", "describe", "interpolate", "interpolate_at"]
