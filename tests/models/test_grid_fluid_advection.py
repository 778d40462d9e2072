"""Semi-Lagrangian advection: constants and affine fields exact under the bilinear
interpolant, the interpolants' orders in h and the backtraces' orders in dt measured."""
import numpy as np
import pytest

from refsim.models.grid_fluid.advection import (BACKTRACES, INTERPOLANTS, advect_cells,
                                                advect_faces, backtrace, catmull_rom_weights,
                                                interpolate_at)
from refsim.models.grid_fluid.mac import MacGrid

EPS = np.finfo(float).eps


def test_catmull_rom_weights_are_a_partition_of_unity_reproducing_quadratics():
    t = np.linspace(0, 1, 11)
    w = np.array(catmull_rom_weights(t))
    nodes = np.array([-1.0, 0.0, 1.0, 2.0])[:, None]
    assert np.allclose(w.sum(axis=0), 1.0, rtol=0, atol=4 * EPS)
    assert np.allclose((w * nodes).sum(axis=0), t, rtol=0, atol=8 * EPS)
    assert np.allclose((w * nodes ** 2).sum(axis=0), t ** 2, rtol=0, atol=16 * EPS)
    assert not np.allclose((w * nodes ** 3).sum(axis=0), t ** 3)  # not cubics: order 3


@pytest.mark.parametrize("stepper", list(BACKTRACES))
def test_uniform_flow_advects_constants_and_affine_fields_exactly_with_bilinear(stepper):
    grid = MacGrid(8, 8, 0.125, (True, True))
    u = np.full((9, 8), 0.3)
    v = np.full((8, 9), -0.2)
    uu, vv = advect_faces(u, v, grid, 0.1, "linear", stepper)
    # a constant is a partition of unity's fixed point: one rounding of the weights' sum
    assert np.max(np.abs(uu - 0.3)) <= 4 * EPS and np.max(np.abs(vv + 0.2)) <= 4 * EPS
    walls = MacGrid(8, 8, 0.125)
    c = walls.cell_points()
    q = 2.0 + 0.5 * c[..., 0] - 1.5 * c[..., 1]
    u0, v0 = np.full((9, 8), 0.3), np.full((8, 9), -0.2)
    u0[[0, -1]] = 0.0
    v0[:, [0, -1]] = 0.0
    # an affine field carried by a uniform flow, inside (the departure points stay inside):
    # q(x - dt U) exactly, up to the rounding of a few operations on values ~ 3
    uniform = MacGrid(8, 8, 0.125, (True, True))
    moved = advect_cells(q, np.full((9, 8), 0.3), np.full((8, 9), -0.2), uniform, 0.1,
                         "linear", stepper)
    exact = 2.0 + 0.5 * (c[..., 0] - 0.03) - 1.5 * (c[..., 1] + 0.02)
    inner = (slice(1, -1), slice(1, -1))
    assert np.max(np.abs(moved[inner] - exact[inner])) <= 64 * EPS * 3


def _interp_error(n, interpolant):
    grid = MacGrid(n, n, 1.0 / n, (True, True))
    c = grid.cell_points()
    f = lambda x, y: np.sin(2 * np.pi * x) * np.cos(2 * np.pi * y)  # noqa: E731
    rng = np.random.default_rng(8)
    pts = rng.uniform(0, 1, (2000, 2))
    got = interpolate_at(f(c[..., 0], c[..., 1]), "cell", pts, grid, interpolant)
    return np.max(np.abs(got - f(pts[:, 0], pts[:, 1])))


@pytest.mark.parametrize("interpolant", list(INTERPOLANTS))
def test_interpolation_order_in_h_measured(interpolant):
    """Max error at random points of a smooth periodic field, h and h/2: linear O(h^2),
    Catmull-Rom O(h^3), clamped Catmull-Rom O(h^2) (the clamp cuts the extrema's h^2 bulge)."""
    e1, e2 = _interp_error(32, interpolant), _interp_error(64, interpolant)
    order = np.log2(e1 / e2)
    expected = INTERPOLANTS[interpolant]
    # a measured order from two max errors at random points: within 0.35 of the theory
    assert abs(order - expected) < 0.35, order


def _rotation(points):
    return np.stack([-(points[..., 1] - 0.5), points[..., 0] - 0.5], axis=-1)


@pytest.mark.parametrize("stepper", list(BACKTRACES))
def test_backtrace_order_in_dt_on_a_rigid_rotation(stepper):
    """The exact departure point rotates x by -dt about the centre; the error of one step is
    O(dt^(q + 1)) for an order-q stepper."""
    x = np.array([[0.8, 0.5], [0.3, 0.7]])

    def error(dt):
        c, s = np.cos(-dt), np.sin(-dt)
        r = x - 0.5
        exact = 0.5 + np.stack([c * r[:, 0] - s * r[:, 1], s * r[:, 0] + c * r[:, 1]], -1)
        return np.max(np.abs(backtrace(x, _rotation, dt, stepper) - exact))
    order = np.log2(error(0.02) / error(0.01)) - 1
    assert abs(order - BACKTRACES[stepper]) < 0.05, order


def test_clamped_cubic_makes_no_new_extrema_and_plain_cubic_does():
    grid = MacGrid(16, 4, 1.0 / 16, (True, True))
    q = np.zeros((16, 4))
    q[8:] = 1.0  # a step
    u, v = np.full((17, 4), 0.37), np.zeros((16, 5))
    plain = advect_cells(q, u, v, grid, 0.1, "cubic", "euler")
    clamped = advect_cells(q, u, v, grid, 0.1, "cubic_clamped", "euler")
    assert plain.min() < -1e-3 and plain.max() > 1 + 1e-3
    assert clamped.min() >= 0.0 and clamped.max() <= 1.0


def test_unknown_names_are_refused():
    grid = MacGrid(4, 4, 0.25)
    with pytest.raises(ValueError, match="interpolant must be one of"):
        advect_faces(np.zeros((5, 4)), np.zeros((4, 5)), grid, 0.1, "quintic")
    with pytest.raises(ValueError, match="backtrace must be one of"):
        advect_faces(np.zeros((5, 4)), np.zeros((4, 5)), grid, 0.1, "linear", "rk4")
