"""A level set advected by a prescribed velocity (issue 27, case 4: LeVeque's single vortex,
Zalesak's slotted disk), with the group's semi-Lagrangian machinery (refsim.models.grid_fluid.
advection: the same backtrace tableaux and interpolants).

phi lives on the cells of the MAC convention (phi[i, j] at ((i + 1/2) h, (j + 1/2) h), walls
with even ghosts: zero normal gradient); the shape is {phi < 0}. One step of dt from t^n to
t^(n+1): phi^(n+1)(x) = I[phi^n](x_d), the departure point x_d of the characteristic ending at
the cell centre x, traced back by the backtrace stepper through the ANALYTIC velocity u(t, x)
(refsim.models.grid_fluid.prescribed_flow), each stage at its own time (`backtrace_timed`:
stage k at t^(n+1) - c_k dt; for a frozen field it is advection.backtrace, bit for bit). No
grid sampling of u: the errors are the interpolant's and the backtrace's only. Optional
reinitialisation (`redistance`, every k-th step; off by default).

Exact signed distances (`disk_sdf`, `slotted_disk_sdf`) and the area rule:
- area of {phi < 0} (`area`): phi is interpolated linearly on 4 triangles per dual cell (the
  square between 4 neighbouring cell centres, split at its centre, whose value is the mean of
  the 4), and the area of {f < 0} of a linear f on a triangle is exact: with the vertex values
  sorted f0 <= f1 <= f2 and the triangle's area a, a f0^2 / ((f1 - f0)(f2 - f0)) when only f0
  < 0, a (1 - f2^2 / ((f2 - f0)(f2 - f1))) when only f2 >= 0 (the similar corner triangle
  cut off by the zero line). The dual cells cover [h/2, L - h/2]^2: shapes must stay inside.
  Its error on a disk of radius r sampled from its exact signed distance is O(h^2 / r) of
  the area (the chords of the zero line; tests/models/test_grid_fluid_level_set.py);
- symmetric difference against an exact shape of signed distance phi_e sampled on the same
  cells (`symmetric_difference`), by the same rule: both interpolated linearly on the same
  triangles, A(phi) + A(phi_e) - 2 A(phi and phi_e), the intersection exact per triangle
  (`_both_fraction`): the computed shape's sub-cell position counts, and phi = phi_e gives 0
  to round-off. A(.) and A(. and phi_e) are monotone in each nodal value of phi (barycentric
  weights >= 0): a perturbation of phi by at most delta changes the symmetric difference by
  at most 3 (A(phi - delta) - A(phi + delta)).
"""
from __future__ import annotations

import numpy as np

from .advection import check, interpolate_at
from .mac import MacGrid


# -- exact signed distances --------------------------------------------------------------------
def disk_sdf(points, centre, radius) -> np.ndarray:
    """|x - c| - r at points (..., 2)."""
    return np.hypot(points[..., 0] - centre[0], points[..., 1] - centre[1]) - radius


def _segment_distance(px, py, ax, ay, bx, by) -> np.ndarray:
    """Distance from points to the segment a-b (the nearest point clamped onto it)."""
    dx, dy = bx - ax, by - ay
    s = np.clip(((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy), 0.0, 1.0)
    return np.hypot(px - ax - s * dx, py - ay - s * dy)


def slotted_disk_sdf(points, centre, radius, width, length) -> np.ndarray:
    """The exact signed distance (negative inside) of Zalesak's slotted disk: the disk
    |x - c| <= R less the slot |x - c_x| < w/2, y < c_y - R + L (open at the bottom).

    Derivation: the shape A is closed and its boundary is (i) the circle's arc outside the slot,
    the points c + R (cos a, sin a) except the bottom arc |R cos a| < w/2, sin a < 0; (ii) the
    slot's two walls, x = c_x -+ w/2 for y from y_b = c_y - sqrt(R^2 - w^2/4) (where they meet
    the circle) to y_t = c_y - R + L; (iii) its end, y = y_t for |x - c_x| <= w/2. The signed
    distance is -+dist(x, boundary), so dist is the minimum over the four pieces. The nearest
    point of the whole circle to x is c + R (x - c)/|x - c| at distance ||x - c| - R|; when it
    lies on the removed bottom arc, the nearest point of the kept arc is one of its two ends
    (the distance to a point of the circle grows monotonically with the angle away from x's
    direction), which are the walls' bottom ends (c_x -+ w/2, y_b), already counted by the
    walls: the arc then contributes nothing. Inside iff |x - c| < R and not in the slot."""
    cx, cy = centre
    px, py = points[..., 0] - cx, points[..., 1] - cy  # relative to the centre
    half = 0.5 * width
    y_b, y_t = -np.sqrt(radius * radius - half * half), -radius + length
    rho = np.hypot(px, py)
    safe = np.where(rho > 0, rho, 1.0)
    on_removed_arc = (np.abs(radius * px / safe) < half) & (py < 0)
    arc = np.where(on_removed_arc, np.inf, np.abs(rho - radius))
    dist = np.minimum.reduce([
        arc,
        _segment_distance(px, py, -half, y_b, -half, y_t),
        _segment_distance(px, py, half, y_b, half, y_t),
        _segment_distance(px, py, -half, y_t, half, y_t)])
    inside = (rho < radius) & ~((np.abs(px) < half) & (py < y_t))
    return np.where(inside, -dist, dist)


# -- area rule -----------------------------------------------------------------------------------
def _triangles(phi) -> np.ndarray:
    """(4, m, 3): the vertex values of the 4 triangles of each dual cell (corners a, b, c, d
    counter-clockwise, centre value their mean)."""
    a, b = phi[:-1, :-1], phi[1:, :-1]
    c, d = phi[1:, 1:], phi[:-1, 1:]
    m = 0.25 * (a + b + c + d)
    return np.stack([np.stack([a, b, m], -1), np.stack([b, c, m], -1),
                     np.stack([c, d, m], -1), np.stack([d, a, m], -1)]).reshape(4, -1, 3)


def _fraction(f) -> np.ndarray:
    """Fraction of a triangle where its linear interpolant of the vertex values f (..., 3)
    is < 0 (module docstring)."""
    f = np.sort(f, axis=-1)
    f0, f1, f2 = f[..., 0], f[..., 1], f[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = np.where(f2 < 0, 1.0, 0.0)
        frac = np.where((f0 < 0) & (f1 >= 0), f0 * f0 / ((f1 - f0) * (f2 - f0)), frac)
        frac = np.where((f1 < 0) & (f2 >= 0), 1.0 - f2 * f2 / ((f2 - f0) * (f2 - f1)), frac)
    return frac


def _both_fraction(f, g) -> np.ndarray:
    """Fraction of a triangle where both linear interpolants (vertex values f, g (..., 3))
    are < 0: {f < 0} cut into at most 2 triangles (barycentric area fractions), g linear on
    each, its negative fraction there by `_fraction`. Vertices sorted by f, f0 <= f1 <= f2:
    only f0 < 0: the corner (V0, P01, P02), P0k at s_k = f0 / (f0 - fk) from V0 along 0-k,
    fraction s_1 s_2; f0, f1 < 0 <= f2: (V0, V1, P21) and (V0, P21, P20), P2k at
    t_k = f2 / (f2 - fk) from V2, fractions 1 - t_1 and t_1 (1 - t_0) (their sum 1 - t_0 t_1,
    the whole less the corner at V2); all < 0: the triangle."""
    order = np.argsort(f, axis=-1)
    f, g = np.take_along_axis(f, order, -1), np.take_along_axis(g, order, -1)
    f0, f1, f2 = f[..., 0], f[..., 1], f[..., 2]
    g0, g1, g2 = g[..., 0], g[..., 1], g[..., 2]
    one, two, three = (f0 < 0) & (f1 >= 0), (f1 < 0) & (f2 >= 0), f2 < 0
    with np.errstate(divide="ignore", invalid="ignore"):
        s1, s2 = np.where(one, f0 / (f0 - f1), 0.0), np.where(one, f0 / (f0 - f2), 0.0)
        t0, t1 = np.where(two, f2 / (f2 - f0), 0.0), np.where(two, f2 / (f2 - f1), 0.0)
    p01, p02 = g0 + s1 * (g1 - g0), g0 + s2 * (g2 - g0)
    p20, p21 = g2 + t0 * (g0 - g2), g2 + t1 * (g1 - g2)
    corner = s1 * s2 * _fraction(np.stack([g0, p01, p02], -1))
    quad = (1.0 - t1) * _fraction(np.stack([g0, g1, p21], -1)) + \
        t1 * (1.0 - t0) * _fraction(np.stack([g0, p21, p20], -1))
    whole = _fraction(np.stack([g0, g1, g2], -1))
    return np.where(three, whole, np.where(two, quad, np.where(one, corner, 0.0)))


def area(phi, h) -> float:
    """Area of {phi < 0} (m^2) by the module's rule (linear on 4 triangles per dual cell);
    only the triangles the zero line cuts are computed, the others count 1 or 0."""
    tri = _triangles(np.asarray(phi, float))
    low, high = tri.min(axis=-1), tri.max(axis=-1)
    cut = (low < 0) & (high >= 0)
    whole = np.count_nonzero(high < 0)
    return float((whole + np.sum(_fraction(tri[cut]))) * (h * h / 4.0))


def intersection_area(phi, psi, h) -> float:
    """Area of {phi < 0} and {psi < 0} by the same rule (both linear on each triangle); only
    triangles where both have a negative vertex and not all are negative are computed."""
    f, g = _triangles(np.asarray(phi, float)), _triangles(np.asarray(psi, float))
    f_high, g_high = f.max(axis=-1), g.max(axis=-1)
    both = (f_high < 0) & (g_high < 0)
    some = (f.min(axis=-1) < 0) & (g.min(axis=-1) < 0) & ~both
    return float((np.count_nonzero(both) + np.sum(_both_fraction(f[some], g[some])))
                 * (h * h / 4.0))


def symmetric_difference(phi, phi_exact, h) -> float:
    """Area of {phi < 0} xor {phi_exact < 0}, both linear on the same triangles:
    A(phi) + A(phi_e) - 2 A(phi and phi_e) (module docstring)."""
    return area(phi, h) + area(phi_exact, h) - 2.0 * intersection_area(phi, phi_exact, h)


# -- reinitialisation ----------------------------------------------------------------------------
def interface_segments(phi, h) -> np.ndarray:
    """(m, 2, 2): the zero line of the area rule's interpolant, one segment per triangle it
    cuts (a linear function's zero line crosses exactly the 2 edges whose ends differ in sign,
    < 0 against >= 0, at t = f_a / (f_a - f_b) from end a)."""
    nx, ny = phi.shape
    xc, yc = (np.arange(nx) + 0.5) * h, (np.arange(ny) + 0.5) * h
    X, Y = np.meshgrid(xc, yc, indexing="ij")
    pos = np.stack([X, Y], -1)
    a, b, c, d = pos[:-1, :-1], pos[1:, :-1], pos[1:, 1:], pos[:-1, 1:]
    m = 0.25 * (a + b + c + d)
    where = np.stack([np.stack([a, b, m], -2), np.stack([b, c, m], -2),
                      np.stack([c, d, m], -2), np.stack([d, a, m], -2)]).reshape(-1, 3, 2)
    f = _triangles(np.asarray(phi, float)).reshape(-1, 3)
    cut = (f.min(axis=-1) < 0) & (f.max(axis=-1) >= 0)
    f, where = f[cut], where[cut]
    fa, fb = f, np.roll(f, -1, axis=-1)  # edges (0, 1), (1, 2), (2, 0)
    pa, pb = where, np.roll(where, -1, axis=-2)
    cross = (fa < 0) != (fb < 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(cross, fa / (fa - fb), 0.0)
    points = pa + t[..., None] * (pb - pa)
    first_two = np.argsort(~cross, axis=-1, kind="stable")[:, :2]
    return np.take_along_axis(points, first_two[..., None], axis=-2)


REINIT_BAND = 6  # cells: redistanced within this many cells of the zero line, clamped beyond


def redistance(phi, h, band: int = REINIT_BAND) -> np.ndarray:
    """phi replaced by the signed distance (sign kept) from each cell centre to the zero line
    of its area-rule interpolant (`interface_segments`: exact to that polyline) within `band`
    cells of a cut dual cell (by brute force over those cells x the segments), and by
    sign x band h beyond (a clamped distance: the far field only keeps its sign)."""
    from scipy.ndimage import binary_dilation
    phi = np.asarray(phi, float)
    seg = interface_segments(phi, h)
    out = np.where(phi < 0, -1.0, 1.0) * band * h
    if len(seg) == 0:
        return out
    tri = _triangles(phi)  # (4, cells - 1 per axis, 3): dual cells cut by the zero line
    cut = ((tri.min(axis=-1) < 0) & (tri.max(axis=-1) >= 0)).reshape(
        4, phi.shape[0] - 1, phi.shape[1] - 1).any(axis=0)
    near = np.zeros(phi.shape, bool)
    near[:-1, :-1] |= cut
    near = binary_dilation(near, iterations=band + 1)  # +1: the dual cell's far corners
    pts = MacGrid(phi.shape[0], phi.shape[1], h).cell_points()[near]
    a, ab = seg[:, 0], seg[:, 1] - seg[:, 0]
    length2 = np.sum(ab * ab, axis=-1)
    dist = np.empty(len(pts))
    step = max(1, 2 ** 21 // len(seg))
    for lo in range(0, len(pts), step):  # chunks of cells (memory), each vectorised
        rel = pts[lo:lo + step, None, :] - a[None]
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.where(length2 > 0, np.sum(rel * ab, axis=-1) / length2, 0.0)
        gap = rel - np.clip(s, 0.0, 1.0)[..., None] * ab
        dist[lo:lo + step] = np.sqrt(np.min(np.sum(gap * gap, axis=-1), axis=1))
    out[near] = np.where(phi[near] < 0, -1.0, 1.0) * np.minimum(dist, band * h)
    return out


# -- advection ----------------------------------------------------------------------------------
STAGE_TIMES = {"euler": (0.0,), "rk2": (0.0, 0.5), "rk3": (0.0, 0.5, 0.75)}  # c_k of each


def backtrace_timed(points, velocity, t1, dt, stepper: str) -> np.ndarray:
    """Departure points at t1 - dt of the characteristics ending at `points` (..., 2) at t1,
    through the time-dependent `velocity(t, points)`: the tableaux of advection.backtrace,
    stage k evaluated at t1 - c_k dt (STAGE_TIMES)."""
    k1 = velocity(t1, points)
    if stepper == "euler":
        return points - dt * k1
    if stepper == "rk2":
        return points - dt * velocity(t1 - 0.5 * dt, points - 0.5 * dt * k1)
    if stepper == "rk3":
        k2 = velocity(t1 - 0.5 * dt, points - 0.5 * dt * k1)
        k3 = velocity(t1 - 0.75 * dt, points - 0.75 * dt * k2)
        return points - dt * ((2.0 / 9.0) * k1 + (1.0 / 3.0) * k2 + (4.0 / 9.0) * k3)
    raise ValueError(f"backtrace must be one of {list(STAGE_TIMES)}, got {stepper!r}")


class LevelSetAdvection:
    """phi on the cells of `grid`, moved by `velocity(t, points)`; `step(dt, n)`;
    `reinit_every` k > 0: phi redistanced (`redistance`) after every k-th step (0: never)."""

    def __init__(self, phi, grid: MacGrid, velocity, interpolant="linear", stepper="rk2",
                 reinit_every: int = 0):
        check(interpolant, stepper)
        self.reinit_every = int(reinit_every)
        self.phi, self.grid, self.velocity = np.array(phi, float), grid, velocity
        self.interpolant, self.stepper, self.t, self.steps = interpolant, stepper, 0.0, 0
        self._points = grid.cell_points()

    def step(self, dt, n=1):
        for _ in range(n):
            t1 = (self.steps + 1) * dt  # t from the step count: no drift of a running sum
            departure = backtrace_timed(self._points, self.velocity, t1, dt, self.stepper)
            self.phi = interpolate_at(self.phi, "cell", departure, self.grid,
                                      self.interpolant, wall="even")
            self.steps += 1
            self.t = t1
            if self.reinit_every and self.steps % self.reinit_every == 0:
                self.phi = redistance(self.phi, self.grid.h)
        return self.phi


__all__ = ["LevelSetAdvection", "STAGE_TIMES", "area", "backtrace_timed",
           "REINIT_BAND", "disk_sdf", "interface_segments", "intersection_area", "redistance",
           "slotted_disk_sdf", "symmetric_difference"]
