"""The level set of the advection tests (refsim.models.grid_fluid.level_set) and the prescribed
flows (refsim.models.grid_fluid.prescribed_flow): the slotted disk's exact signed distance, the
area rule, the symmetric difference, exact advection of a linear phi by a constant flow, the
timed backtrace (advection.backtrace's tableaux, their orders on a time-dependent flow)."""
import math

import numpy as np
import pytest
from scipy.spatial import cKDTree
from ulp import assert_ulp

from refsim.models.grid_fluid.advection import backtrace
from refsim.models.grid_fluid.level_set import (REINIT_BAND, LevelSetAdvection, area,
                                                backtrace_timed, disk_sdf, intersection_area,
                                                redistance, slotted_disk_sdf,
                                                symmetric_difference)
from refsim.models.grid_fluid.mac import MacGrid
from refsim.models.grid_fluid.prescribed_flow import Flow
from refsim.scene.prescribed_flow import PrescribedFlow

C, R, W, L = (50.0, 75.0), 15.0, 5.0, 25.0
EPS = np.finfo(float).eps


def _slotted_boundary(per_unit=400):
    """Dense points on the slotted disk's boundary (spacing 1/per_unit m)."""
    y_b, y_t = C[1] - math.sqrt(R * R - W * W / 4), C[1] - R + L
    a = np.linspace(0, 2 * np.pi, int(2 * np.pi * R * per_unit), endpoint=False)
    arc = np.column_stack([C[0] + R * np.cos(a), C[1] + R * np.sin(a)])
    arc = arc[~((np.abs(arc[:, 0] - C[0]) < W / 2) & (arc[:, 1] < y_t))]
    s = np.linspace(0.0, 1.0, int((y_t - y_b) * per_unit) + 1)
    left = np.column_stack([np.full_like(s, C[0] - W / 2), y_b + s * (y_t - y_b)])
    right = np.column_stack([np.full_like(s, C[0] + W / 2), y_b + s * (y_t - y_b)])
    s = np.linspace(0.0, 1.0, int(W * per_unit) + 1)
    top = np.column_stack([C[0] - W / 2 + s * W, np.full_like(s, y_t)])
    return np.concatenate([arc, left, right, top])


def test_slotted_disk_signed_distance_at_hand_points():
    y_b = C[1] - math.sqrt(R * R - W * W / 4)
    points = np.array([[50.0, 75.0],    # in the slot: 2.5 m from either wall
                       [50.0, 88.0],    # above the slot's end (y = 85): 2 m below the circle
                       [50.0, 95.0],    # above the disk: 5 m outside
                       [50.0, 40.0],    # below: nearest the walls' bottom ends
                       [30.0, 75.0],    # left of the disk: 5 m out
                       [44.0, 70.0]])   # inside, left of the slot: 3.5 m from its wall
    want = [2.5, -2.0, 5.0, math.hypot(2.5, y_b - 40.0), 5.0, -3.5]
    # the closed forms against these sums and square roots: a few roundings of 100 m numbers
    assert_ulp(slotted_disk_sdf(points, C, R, W, L), want, 64, "a few roundings of the "
               "coordinates (|x| <= 100 m) and one hypot", scale=100.0)


def test_slotted_disk_signed_distance_against_a_dense_boundary():
    """|sdf| equals the distance to 6 x 10^4 boundary points (spacing 2.5e-3 m: a point 0.05 m
    or more away sees at most (1.25e-3)^2 / (2 x 0.05) = 1.6e-5 m of sampling error); the sign
    says inside."""
    tree = cKDTree(_slotted_boundary())
    rng = np.random.default_rng(3)
    points = rng.uniform([25.0, 50.0], [75.0, 100.0], size=(5000, 2))
    got = slotted_disk_sdf(points, C, R, W, L)
    dist, _ = tree.query(points)
    far = np.abs(got) > 0.05
    assert np.max(np.abs(np.abs(got[far]) - dist[far])) < 1.6e-5  # the sampling error above
    rel = points - C
    inside = (np.hypot(*rel.T) < R) & ~((np.abs(rel[:, 0]) < W / 2) & (rel[:, 1] < L - R))
    assert np.array_equal(got < 0, inside)


@pytest.mark.parametrize("stepper", ["euler", "rk2", "rk3"])
def test_timed_backtrace_is_the_groups_backtrace_on_a_frozen_field(stepper):
    """Same operations in the same order when the field ignores t: bit for bit."""
    flow = Flow(PrescribedFlow("leveque_vortex", period=3.0))
    pts = MacGrid(16, 16, 1 / 16).cell_points()
    frozen = lambda x: flow.velocity_2d(0.4, x)  # noqa: E731
    got = backtrace_timed(pts, lambda t, x: frozen(x), 1.0, 0.01, stepper)
    assert np.array_equal(got, backtrace(pts, frozen, 0.01, stepper))


def test_timed_backtrace_orders_on_the_single_vortex():
    """Backtraces composed from t = 0.35 T down to 0 against a converged trace (rk3, 2560
    steps: its error ~ 1e-12): the error falls as dt^q, q = 1, 2, 3. (Over the whole [0, T]
    the flow's time symmetry cancels rk2's second-order term: order 3 there.) Stage times
    wrong (every stage at t^(n+1): a frozen field) would leave rk2 and rk3 at order 1."""
    flow = Flow(PrescribedFlow("leveque_vortex", period=1.0))
    start = np.column_stack([0.5 + 0.15 * np.cos(np.linspace(0, 6, 50)),
                             0.75 + 0.15 * np.sin(np.linspace(0, 6, 50))])

    def trace(n, stepper, t1=0.35):
        x, dt = start.copy(), t1 / n
        for k in range(n, 0, -1):  # up to 2560 vectorised steps over 50 points
            x = backtrace_timed(x, flow.velocity_2d, k * dt, dt, stepper)
        return x
    exact = trace(2560, "rk3")
    for stepper, q in (("euler", 1), ("rk2", 2), ("rk3", 3)):
        errs = [np.max(np.abs(trace(n, stepper) - exact)) for n in (20, 40)]
        assert abs(math.log2(errs[0] / errs[1]) - q) < 0.25, (stepper, errs)  # asymptotic


def test_area_rule_exact_for_a_half_plane_and_second_order_on_the_disk():
    g = MacGrid(40, 40, 1 / 40)
    x = g.cell_points()[..., 0]
    # linear phi: the piecewise-linear interpolant is phi itself; the dual cells cover
    # [h/2, 1 - h/2]^2; sums of 6400 fractions: 1e4 eps of the area
    assert_ulp(area(x - 0.37, g.h), (0.37 - g.h / 2) * (1 - g.h), 1e4,
               "6400 triangle fractions summed", scale=0.4)
    errors = []
    for n in (32, 64, 128):
        g = MacGrid(n, n, 1 / n)
        exact = math.pi * 0.15 ** 2
        errors.append(area(disk_sdf(g.cell_points(), (0.5, 0.75), 0.15), g.h) / exact - 1)
    # measured -7.0e-3, -1.8e-3, -4.6e-4: chords of the zero line, O(h^2 / r^2)
    assert all(-(n_h := (1 / n) / 0.15) ** 2 < e < 0 for n, e in zip((32, 64, 128), errors))
    assert abs(math.log2(errors[0] / errors[1]) - 2) < 0.1
    assert abs(math.log2(errors[1] / errors[2]) - 2) < 0.1


def test_symmetric_difference_of_half_planes_and_of_a_shape_with_itself():
    g = MacGrid(40, 40, 1 / 40)
    x = g.cell_points()[..., 0]
    got = symmetric_difference(x - 0.3, x - 0.45, g.h)
    assert_ulp(got, 0.15 * (1 - g.h), 1e4, "6400 fractions summed, three areas", scale=0.4)
    assert_ulp(intersection_area(x - 0.3, x - 0.45, g.h), (0.3 - g.h / 2) * (1 - g.h), 1e4,
               "6400 fractions summed", scale=0.4)
    phi = disk_sdf(g.cell_points(), (0.5, 0.5), 0.3)
    # phi against itself: every cut triangle's intersection equals its own area to round-off
    assert abs(symmetric_difference(phi, phi, g.h)) < 1e3 * EPS * area(phi, g.h)


@pytest.mark.parametrize("interpolant", ["linear", "cubic", "cubic_clamped"])
@pytest.mark.parametrize("stepper", ["euler", "rk2", "rk3"])
def test_constant_flow_advects_a_linear_phi_exactly(interpolant, stepper):
    """u constant: every backtrace is exact (x - dt u), every interpolant reproduces a linear
    phi; cells whose stencils stay 3 cells inside the walls (the even ghosts are not linear)
    hold phi_0(x - u t) to round-off."""
    g = MacGrid(24, 24, 1 / 24)
    u = np.array([0.31, -0.17])
    phi0 = lambda x: 0.8 * x[..., 0] - 0.6 * x[..., 1] + 0.1  # noqa: E731
    model = LevelSetAdvection(phi0(g.cell_points()), g, lambda t, x: np.broadcast_to(
        u, x.shape), interpolant, stepper)
    dt = 0.9 * g.h / np.max(np.abs(u))
    model.step(dt, 2)
    want = phi0(g.cell_points() - 2 * dt * u)
    inner = (slice(5, -5), slice(5, -5))  # 2 steps of < 1 cell plus a 2-cell stencil: inside
    # phi ~ 1, x ~ 1: each step rounds the departure point and the weighted sum of <= 16 values
    assert_ulp(model.phi[inner], want[inner], 256, "two steps of departure points and weighted "
               "sums of up to 16 values, each rounding at eps of ~1", scale=1.0)


def test_flows():
    """Single vortex: divergence-free (central differences, O(d^2)), no flow through the unit
    square's sides, reversed at T - t; the rotation: omega times the distance, tangential."""
    sv = Flow(PrescribedFlow("leveque_vortex", period=2.0))
    rng = np.random.default_rng(5)
    x = rng.uniform(0.05, 0.95, size=(200, 2))
    d = 1e-5
    div = (sv.velocity_2d(0.3, x + [d, 0])[:, 0] - sv.velocity_2d(0.3, x - [d, 0])[:, 0] +
           sv.velocity_2d(0.3, x + [0, d])[:, 1] - sv.velocity_2d(0.3, x - [0, d])[:, 1]) / (2 * d)
    assert np.max(np.abs(div)) < 1e-8  # central differences: (2 pi)^3 d^2 ~ 2.5e-8 x 0.4
    side = np.column_stack([np.zeros(20), np.linspace(0, 1, 20)])
    assert np.max(np.abs(sv.velocity_2d(0.3, side)[:, 0])) < 1e-30 + 1e-15  # sin^2(0) = 0
    assert_ulp(sv.velocity_2d(2.0 - 0.3, x), -sv.velocity_2d(0.3, x), 8,
               "cos(pi (T - t)/T) = -cos(pi t/T) to a few roundings of the argument",
               scale=1.0)
    rot = Flow(PrescribedFlow("zalesak_rotation", omega=math.pi / 314, centre=(50, 50)))
    p = np.array([[50.0, 75.0], [80.0, 50.0]])
    assert_ulp(rot.velocity_2d(0.0, p), [[-25 * math.pi / 314, 0.0], [0.0, 30 * math.pi / 314]],
               2, "one product each", scale=0.3)
    assert rot.linear and not sv.linear


@pytest.mark.parametrize("n", [32, 64])
def test_redistance_of_a_disk_is_its_distance_to_the_chords(n):
    """Within the band, the distance to the interpolant's zero line (chords of length <= h)
    differs from the disk's exact distance by at most the chords' sagitta h^2 / (8 r) plus
    the zero crossings' own interpolation error h^2 / (8 r) (a linear interpolant of the
    distance, |phi''| <= 1/r near the circle): h^2 / (4 r); measured 8.0e-4 and 2.0e-4 against
    1.6e-3 and 4.1e-4. Beyond the band: sign x band h; the sign is kept everywhere."""
    g, r = MacGrid(n, n, 1 / n), 0.15
    phi = disk_sdf(g.cell_points(), (0.5, 0.5), r)
    got = redistance(phi, g.h)
    assert np.array_equal(got < 0, phi < 0)
    near = np.abs(got) < REINIT_BAND * g.h
    assert np.max(np.abs(got - phi)[near]) <= g.h ** 2 / (4 * r)
    assert np.all(np.abs(got[~near]) == REINIT_BAND * g.h)
    assert np.count_nonzero(near) > 2 * np.pi * r / g.h * 2 * (REINIT_BAND - 1)  # the band
