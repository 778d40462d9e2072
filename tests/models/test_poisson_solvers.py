"""The Poisson solvers (refsim.models.poisson_solvers, refsim.models.multigrid): every method
meets its residual target and agrees with the exact discrete solution and with the direct
solve to the bound the residual implies; multigrid converges in a grid-independent number of
cycles; the space error of the 5-point scheme is O(h^2)."""
import math

import numpy as np
import pytest

from refsim.models.multigrid import GeometricMultigrid, prolong, restrict
from refsim.models.poisson_solvers import METHODS, PoissonProblem, solve_problem
from refsim.scene.grids import Grid

EPS = np.finfo(float).eps
RTOL = 1e-8


def unit_grid(dim, n):
    x = np.linspace(0.0, 1.0, n)
    return np.meshgrid(*([x] * dim), indexing="ij"), 1.0 / (n - 1)


def sine_problem(dim, n):
    """f = -d pi^2 prod sin(pi x): u_h = [pi^2 h^2 / (4 sin^2(pi h/2))] prod sin(pi x)."""
    axes, h = unit_grid(dim, n)
    s = np.prod([np.sin(np.pi * a) for a in axes], axis=0)
    s[~PoissonProblem((n,) * dim, (h,) * dim, s, s).free] = 0.0
    factor = (np.pi * h) ** 2 / (4 * np.sin(np.pi * h / 2) ** 2)
    return PoissonProblem((n,) * dim, (h,) * dim, np.zeros_like(s), -dim * np.pi ** 2 * s), \
        factor * s, dim * 4 / h ** 2 * np.sin(np.pi * h / 2) ** 2


def rough_problem(dim, n, seed=3):
    """A rhs of every mode (seeded normal values): CG gains nothing from a lone eigenvector."""
    _, h = unit_grid(dim, n)
    f = np.random.default_rng(seed).standard_normal((n,) * dim)
    return PoissonProblem((n,) * dim, (h,) * dim, np.zeros((n,) * dim), f)


def error_bound(problem, residual, lam_min, u_scale):
    """||e||_2 <= ||r||_2 / lambda_min, ||r||_2 = residual ||f||_2 (as computed), plus the
    residual's own evaluation round-off (2d+1) eps (4d/h^2) ||u||_2 (Higham's bound for a sum
    of 2d+1 terms, |L| row sums 4d/h^2)."""
    d, h = len(problem.shape), problem.spacing[0]
    return (residual * problem.rhs_norm + (2 * d + 1) * EPS * 4 * d / h ** 2 * u_scale) / lam_min


@pytest.mark.parametrize("dim, n", [(2, 33), (3, 17)])
@pytest.mark.parametrize("method", METHODS)
def test_every_solver_reaches_the_exact_discrete_solution(method, dim, n):
    problem, exact, lam = sine_problem(dim, n)
    u, info = solve_problem(problem, method, RTOL)
    assert info["residual"] <= RTOL
    assert info["iterations"] >= 1 and info["setup_s"] >= 0 and info["solve_s"] >= 0
    scale = np.linalg.norm(exact)
    # the reference's own rounding: sin of rounded pi x, d factors (<= 2^(d/2) d (2 pi + 2)
    # eps ||u_h||, in f and in u_h) - see cases/grid_poisson/poisson_manufactured.py
    roundoff = (2 * 2 ** (dim / 2) * dim * (2 * math.pi + 2) + 1) * EPS * scale
    assert np.linalg.norm(u - exact) <= error_bound(problem, info["residual"], lam, scale) \
        + roundoff


@pytest.mark.parametrize("dim, n", [(2, 33), (3, 17)])
@pytest.mark.parametrize("method", ("cg", "multigrid", "pyamg"))
def test_iterative_solvers_agree_with_the_direct_solve(method, dim, n):
    """A rough rhs: u_m - u_direct = L^-1 (r_direct - r_m), so ||u_m - u_direct|| <=
    (||r_m|| + ||r_direct||) / lambda_min plus both residuals' evaluation round-off."""
    direct, info_direct = solve_problem(rough_problem(dim, n), "direct", RTOL)
    problem = rough_problem(dim, n)
    u, info = solve_problem(problem, method, RTOL)
    h = problem.spacing[0]
    lam = dim * 4 / h ** 2 * np.sin(np.pi * h / 2) ** 2
    scale = np.linalg.norm(direct)
    bound = error_bound(problem, info["residual"], lam, scale) + \
        error_bound(problem, info_direct["residual"], lam, scale)
    assert info["residual"] <= RTOL
    assert np.linalg.norm(u - direct) <= bound


@pytest.mark.parametrize("method", METHODS)
def test_boundary_values_enter_the_rhs(method):
    """u = x^2 + y^2: second differences of a quadratic are exact, so L_h u = 4 and u itself
    is the discrete solution for its own boundary values (none of them zero on x = 1)."""
    (x, y), h = unit_grid(2, 33)
    exact = x ** 2 + y ** 2
    problem = PoissonProblem(exact.shape, (h, h), np.where(PoissonProblem(
        exact.shape, (h, h), exact, exact).free, 0.0, exact), np.full(exact.shape, 4.0))
    u, info = solve_problem(problem, method, RTOL)
    lam = 2 * 4 / h ** 2 * np.sin(np.pi * h / 2) ** 2
    assert info["residual"] <= RTOL
    assert np.all(u[~problem.free] == exact[~problem.free])
    assert np.linalg.norm(u - exact) <= error_bound(problem, info["residual"], lam,
                                                    np.linalg.norm(exact))


@pytest.mark.parametrize("mode", ("pcg", "vcycle"))
def test_multigrid_iterations_do_not_grow_with_the_grid(mode):
    """Multigrid's contraction per cycle is independent of h (measured 0.056 per V(2,2) cycle
    at N = 65 and 257, the local Fourier analysis value for two red-black sweeps being
    0.074): to the same rtol the count may move by the rounding of the last cycle only, while
    unpreconditioned CG's grows like N (its condition number ~ N^2)."""
    counts = [solve_problem(rough_problem(2, n), "multigrid", RTOL, {"mode": mode})[1]
              ["iterations"] for n in (33, 65, 129, 257)]
    assert max(counts) - min(counts) <= 1, counts
    cg = [solve_problem(rough_problem(2, n), "cg", RTOL)[1]["iterations"] for n in (33, 65)]
    assert cg[1] > 1.5 * cg[0]  # doubling N about doubles CG's count


def test_space_error_is_second_order():
    """max |u_h - u| = (factor - 1) max|u|, factor - 1 = (pi h)^2/12 + (pi h)^4/240 + ...:
    the fitted order over N = 17..129 is 2 up to the next term's pull 2 (pi h)^2/20 <= 0.004
    at h = 1/16; 0.05 leaves the solver's 1e-8-relative share room."""
    hs, errs = [], []
    for n in (17, 33, 65, 129):
        problem, _, _ = sine_problem(2, n)
        u, _ = solve_problem(problem, "multigrid", RTOL)
        axes, h = unit_grid(2, n)
        hs.append(h)
        errs.append(np.max(np.abs(u - np.sin(np.pi * axes[0]) * np.sin(np.pi * axes[1]))))
    order = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert abs(order - 2.0) <= 0.05


def test_transfer_operators_are_adjoint():
    """Full weighting is 2^-d times the transpose of linear interpolation (both are tensor
    products of (1/4, 1/2, 1/4) and (1/2, 1, 1/2)): <R r, e> 2^d = <r, P e>."""
    rng = np.random.default_rng(7)
    for dim in (1, 2, 3):
        fine, coarse = (9,) * dim, (5,) * dim
        r, e = np.zeros(fine), np.zeros(coarse)
        inner = tuple(slice(1, -1) for _ in range(dim))
        r[inner] = rng.standard_normal(r[inner].shape)
        e[inner] = rng.standard_normal(e[inner].shape)
        lhs, rhs = 2 ** dim * np.vdot(restrict(r, coarse), e), np.vdot(r, prolong(e, fine))
        assert abs(lhs - rhs) <= 1e-13 * (abs(lhs) + 1)  # sums of ~10^3 O(1) products


def test_preconditioner_is_symmetric():
    """The V-cycle from zero with mirrored post-sweeps is a symmetric operator: <M a, b> =
    <a, M b> up to round-off, as CG needs."""
    n, h = 17, 1 / 16
    mg = GeometricMultigrid((n, n), (h, h))
    rng = np.random.default_rng(11)
    a, b = np.zeros((n, n)), np.zeros((n, n))
    a[1:-1, 1:-1], b[1:-1, 1:-1] = rng.standard_normal((2, n - 2, n - 2))
    lhs, rhs = np.vdot(mg.precondition(a), b), np.vdot(a, mg.precondition(b))
    assert abs(lhs - rhs) <= 1e-12 * abs(lhs)


def test_bad_input_is_refused_with_the_reason():
    problem = rough_problem(2, 20)
    with pytest.raises(ValueError, match="2\\^k \\+ 1 points per axis"):
        solve_problem(problem, "multigrid", RTOL)
    with pytest.raises(ValueError, match="method must be one of"):
        solve_problem(problem, "jacobi", RTOL)
    with pytest.raises(ValueError, match="rtol must be in"):
        solve_problem(problem, "cg", 0.0)
    _, info = solve_problem(problem, "cg", RTOL)  # non-2^k+1 grids: the other methods
    assert info["residual"] <= RTOL
    neumann = Grid(shape=(9, 9), spacing=0.125, model="poisson", boundary="neumann",
                   fields={"u": np.zeros((9, 9)), "f": np.zeros((9, 9))})
    with pytest.raises(ValueError, match="every side Dirichlet"):
        PoissonProblem.of(neumann)
