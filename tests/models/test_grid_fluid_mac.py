"""MAC operators: the divergence of a discrete curl is exactly zero, D G is the 5-point
Laplacian inside, the gradient's sign and seams, and bilinear sampling with its ghosts."""
import numpy as np
import pytest

from refsim.models.grid_fluid.mac import (MacGrid, cells_to_faces, divergence,
                                          enforce_boundaries, faces_to_cells, gradient, sample,
                                          velocity_at)


def curl(psi, h):
    """u = d psi / dy, v = -d psi / dx from node values psi (nx + 1, ny + 1)."""
    return np.diff(psi, axis=1) / h, -np.diff(psi, axis=0) / h


@pytest.mark.parametrize("periodic", [(False, False), (True, True), (True, False)])
def test_divergence_of_a_discrete_curl_is_exactly_zero(periodic):
    """Dyadic node values and h = 1/8: every difference and quotient is exact, so D curl psi
    is 0 bit for bit (exact arithmetic, same operations)."""
    rng = np.random.default_rng(1)
    psi = rng.integers(-2 ** 20, 2 ** 20, (9, 7)) / 2.0 ** 20
    u, v = curl(psi, 0.125)
    assert np.array_equal(divergence(u, v, 0.125), np.zeros((8, 6)))


def _laplacian_inner(p, h):
    return (p[2:, 1:-1] + p[:-2, 1:-1] + p[1:-1, 2:] + p[1:-1, :-2] - 4 * p[1:-1, 1:-1]) / h ** 2


def test_divergence_of_the_gradient_is_the_five_point_laplacian_inside():
    rng = np.random.default_rng(2)
    grid = MacGrid(7, 6, 0.1)
    p = rng.standard_normal((7, 6))
    dg = divergence(*gradient(p, grid), grid.h)
    # different operation order: each side rounds ~6 operations on values of |p| / h^2
    bound = 16 * np.finfo(float).eps * np.abs(p).max() * 8 / grid.h ** 2
    assert np.max(np.abs(dg[1:-1, 1:-1] - _laplacian_inner(p, grid.h))) <= bound
    # at a wall the missing neighbour is a zero flux (homogeneous Neumann)
    edge = (p[1, 2] - p[0, 2] + p[0, 3] - 2 * p[0, 2] + p[0, 1]) / grid.h ** 2
    assert dg[0, 2] == pytest.approx(edge, rel=1e-13, abs=bound)


def test_gradient_sign_and_periodic_seam():
    grid = MacGrid(4, 3, 0.5, (True, False))
    p = np.arange(12.0).reshape(4, 3)  # p = 3 i + j
    gu, gv = gradient(p, grid)
    assert np.all(gu[1:4] == 3 / 0.5) and np.all(gv[:, 1:3] == 1 / 0.5)
    assert np.all(gu[0] == (p[0] - p[3]) / 0.5) and np.array_equal(gu[4], gu[0])
    assert np.all(gv[:, 0] == 0) and np.all(gv[:, 3] == 0)  # walls along y


def test_face_cell_averages_and_boundaries():
    grid = MacGrid(3, 2, 1.0)
    u = np.arange(8.0).reshape(4, 2)
    v = np.arange(9.0).reshape(3, 3)
    uc, vc = faces_to_cells(u, v)
    assert np.array_equal(uc, 0.5 * (u[1:] + u[:-1])) and vc.shape == (3, 2)
    fu, fv = cells_to_faces(np.ones((3, 2)), grid)
    assert fu.shape == (4, 2) and fv.shape == (3, 3) and np.all(fu == 1) and np.all(fv == 1)
    enforce_boundaries(u, v, grid)
    assert np.all(u[[0, -1]] == 0) and np.all(v[:, [0, -1]] == 0)


@pytest.mark.parametrize("periodic", [(False, False), (True, True)])
def test_bilinear_sampling_is_exact_on_bilinear_fields_and_at_faces(periodic):
    grid = MacGrid(6, 5, 0.2, periodic)
    rng = np.random.default_rng(3)
    pts = rng.uniform([0.2, 0.2], [1.0, 0.8], (50, 2))  # away from the ghost rows
    q = 1.5 + 0.3 * grid.cell_points()[..., 0] - 0.7 * grid.cell_points()[..., 1]
    exact = 1.5 + 0.3 * pts[:, 0] - 0.7 * pts[:, 1]
    # bilinear reproduces affine data: rounding of a few operations on values ~ 2
    assert np.max(np.abs(sample(q, "cell", pts, grid) - exact)) < 1e-14
    u = rng.standard_normal((7, 5))
    u[-1] = u[0] if periodic[0] else 0.0
    if not periodic[0]:
        u[0] = 0.0
    at_faces = sample(u, "u", grid.u_points(), grid)
    # x / h of a face rounds by up to n eps in index units (5.999... for the last face of a
    # periodic axis): the interpolant moves by that times a neighbour difference <= 2 max|u|
    bound = 2 * 6 * np.finfo(float).eps * 2 * np.abs(u).max()
    assert np.max(np.abs(at_faces - u)) <= bound


def test_no_slip_ghosts_give_the_wall_velocity_on_the_wall():
    grid = MacGrid(4, 4, 0.25, lid=2.0)
    rng = np.random.default_rng(4)
    u = rng.standard_normal((5, 4))
    u[[0, -1]] = 0.0
    v = np.zeros((4, 5))
    x = np.linspace(0.1, 0.9, 7)
    top = velocity_at(u, v, np.stack([x, np.ones(7)], axis=-1), grid)
    bottom = velocity_at(u, v, np.stack([x, np.zeros(7)], axis=-1), grid)
    # the ghost 2 w - u_0 averages with u_0 to w: exact up to one rounding of 2 w - u_0
    assert np.allclose(top[:, 0], 2.0, rtol=0, atol=1e-15 * 8)
    assert np.allclose(bottom[:, 0], 0.0, rtol=0, atol=1e-15 * 8)
    # outside the domain the point is clamped onto the wall
    assert np.allclose(velocity_at(u, v, np.array([[0.5, 1.7]]), grid)[0, 0], 2.0, atol=1e-14)
