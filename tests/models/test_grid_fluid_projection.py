"""The MAC pressure projection: A = G^T G is -(D G) (the 5-point Laplacian inside), the
projected field is divergence-free to the solver's tolerance, the projection is idempotent,
a gradient is removed and a discrete curl kept, free-surface and solid marks."""
import numpy as np
import pytest

from refsim.models.grid_fluid.mac import MacGrid, divergence, gradient
from refsim.models.grid_fluid.projection import ALL_METHODS, PressureSystem
from refsim.scene.fluid_grid import AIR, FLUID, SOLID

EPS = np.finfo(float).eps


def _random_faces(grid, rng):
    u = rng.standard_normal((grid.nx + 1, grid.ny))
    v = rng.standard_normal((grid.nx, grid.ny + 1))
    for arr, axis in ((u, 0), (v, 1)):
        first, last = [slice(None)] * 2, [slice(None)] * 2
        first[axis], last[axis] = 0, -1
        if grid.periodic[axis]:
            arr[tuple(last)] = arr[tuple(first)]
        else:
            arr[tuple(first)] = arr[tuple(last)] = 0.0
    return u, v


def test_matrix_is_minus_d_g_and_the_five_point_laplacian_inside():
    grid = MacGrid(6, 5, 0.125)  # h a power of 2: entries exact
    system = PressureSystem(grid)
    A = system.A.toarray()
    rng = np.random.default_rng(5)
    p = rng.standard_normal((6, 5))
    dg = divergence(*gradient(p, grid), grid.h).ravel()
    # A p and -D G p: the same sums in another order, |terms| <= 8 |p| / h^2
    assert np.max(np.abs(A @ p.ravel() + dg)) <= 16 * EPS * 8 * np.abs(p).max() / grid.h ** 2
    inner = 2 * 5 + 2  # cell (2, 2): diagonal 4 / h^2, four neighbours -1 / h^2
    assert A[inner, inner] == 4 / grid.h ** 2
    assert sorted(A[inner][A[inner] != 0])[:4] == [-1 / grid.h ** 2] * 4
    assert A[0, 0] == 2 / grid.h ** 2  # a corner cell: two walls, Neumann
    assert np.array_equal(A, A.T)


@pytest.mark.parametrize("method", ALL_METHODS)
@pytest.mark.parametrize("periodic", [(False, False), (True, True), (True, False)])
def test_projection_is_divergence_free_to_tolerance_and_idempotent(method, periodic):
    grid = MacGrid(12, 10, 0.1, periodic)
    system = PressureSystem(grid)
    u, v = _random_faces(grid, np.random.default_rng(6))
    dt, rtol = 0.05, 1e-10
    un, vn, p, info = system.project(u, v, dt, method, rtol)
    assert info["residual"] <= rtol
    b_norm = np.linalg.norm(system.rhs(u, v, dt))
    # D u_new = -dt (b - A p): |D u| <= dt ||r||_2 <= dt rtol ||b||_2 (plus the rounding of
    # the final face update, eps |u| / h per face, 4 faces)
    assert info["divergence"] <= dt * rtol * b_norm + 4 * 4 * EPS * np.abs(u).max() / grid.h
    assert abs(p.mean()) <= 1e-12 * np.abs(p).max()  # the null space: mean fixed to 0
    u2, v2, p2, info2 = system.project(un, vn, dt, method, rtol)
    # idempotent: the second projection's rhs is the first's residual (<= rtol ||b||)
    change = max(np.abs(u2 - un).max(), np.abs(v2 - vn).max())
    assert change <= 10 * rtol * b_norm * dt + 1e-13
    if periodic[0]:
        assert np.array_equal(un[0], un[-1])


@pytest.mark.parametrize("method", ALL_METHODS)
def test_a_gradient_is_removed_and_a_curl_kept(method):
    """u* = curl psi + G phi projects to curl psi: the error is G e with A e = r, so
    ||G e||_2 <= ||r||_2 / sqrt(lambda_min), lambda_min = (4 / h^2) sin^2(pi h / (2 L))."""
    n, h = 16, 1.0 / 16
    grid = MacGrid(n, n, h)
    x = np.arange(n + 1) * h
    psi = np.outer(np.sin(np.pi * x), np.sin(2 * np.pi * x)) ** 2  # 0 on the walls
    psi = np.round(psi * 2.0 ** 40) / 2.0 ** 40  # dyadic: the curl's divergence is exactly 0
    u_df, v_df = np.diff(psi, axis=1) / h, -np.diff(psi, axis=0) / h
    assert np.array_equal(divergence(u_df, v_df, h), np.zeros((n, n)))
    c = grid.cell_points()
    phi = np.cos(np.pi * c[..., 0]) * np.cos(3 * np.pi * c[..., 1])
    gu, gv = gradient(phi, grid)
    system = PressureSystem(grid)
    rtol = 1e-9
    un, vn, p, info = system.project(u_df + gu, v_df + gv, 1.0, method, rtol)
    err = np.sqrt(np.sum((un - u_df) ** 2) + np.sum((vn - v_df) ** 2))
    lam = 4 / h ** 2 * np.sin(np.pi * h / 2) ** 2
    b_norm = np.linalg.norm(system.rhs(u_df + gu, v_df + gv, 1.0))
    assert err <= info["residual"] * b_norm / np.sqrt(lam) + 1e-13
    assert err <= rtol * b_norm / np.sqrt(lam) + 1e-13
    assert np.max(np.abs(p - (phi - phi.mean()))) <= rtol * b_norm / lam + 1e-12


def test_free_surface_cells_hold_zero_pressure_and_solid_faces_stay_fixed():
    grid = MacGrid(8, 8, 0.125)
    marks = np.full((8, 8), FLUID, np.int8)
    marks[:, 5:] = AIR
    marks[3, 1] = SOLID
    system = PressureSystem(grid, marks)
    assert not system.singular
    u, v = _random_faces(grid, np.random.default_rng(7))
    u[3:5, 1] = 0.0
    v[3, 1:3] = 0.0
    un, vn, p, info = system.project(u, v, 0.1, "direct", 1e-12)
    assert np.all(p[marks != FLUID] == 0.0)
    assert np.array_equal(un[3:5, 1], [0.0, 0.0]) and np.array_equal(vn[3, 1:3], [0.0, 0.0])
    div = divergence(un, vn, grid.h)[marks == FLUID]
    assert np.max(np.abs(div)) <= info["divergence"] <= 1e-10
    # faces between two air cells are not active: their velocity is left as it was
    assert np.array_equal(un[3, 6], u[3, 6])


def test_unknown_method_is_refused():
    with pytest.raises(ValueError, match="projection method must be one of"):
        PressureSystem(MacGrid(4, 4, 0.25)).solve(np.ones(16), "jacobi")


def test_multigrid_preconditioner_is_symmetric_and_its_iterations_do_not_grow_with_n():
    from refsim.models.grid_fluid.projection_mg import CellMultigrid
    grid = MacGrid(16, 12, 1.0 / 16, (True, False))
    mg = CellMultigrid(grid)
    rng = np.random.default_rng(10)
    r1, r2 = rng.standard_normal(192), rng.standard_normal(192)
    r1 -= r1.mean()
    r2 -= r2.mean()
    a, b = r2 @ mg.precondition(r1), r1 @ mg.precondition(r2)
    # symmetric V-cycle (R = P^T / 4, adjoint sweeps): equal up to the rounding of two
    # different operation orders through ~levels x sweeps array passes
    assert abs(a - b) <= 1e-12 * (abs(a) + abs(b))
    counts = []
    for n in (32, 128):
        g = MacGrid(n, n, 1.0 / n)
        u, v = _random_faces(g, rng)
        counts.append(PressureSystem(g).project(u, v, 0.1, "multigrid", 1e-10)[3]["iterations"])
    assert max(counts) <= 12 and counts[1] <= counts[0] + 2, counts  # measured 8 and 8


def test_multigrid_refuses_marks_and_odd_grids_with_the_reason():
    marks = np.zeros((8, 8), np.int8)
    marks[:, 6:] = AIR
    with pytest.raises(ValueError, match="grids of fluid cells only"):
        PressureSystem(MacGrid(8, 8, 0.125), marks).solve(np.ones(48), "multigrid")
    with pytest.raises(ValueError, match="cells per axis even"):
        PressureSystem(MacGrid(9, 8, 0.125)).solve(np.ones(72) - 1 + np.arange(72) % 2,
                                                    "multigrid")
