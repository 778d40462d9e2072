"""P1 Poisson on triangle meshes (refsim.models.fem.poisson): on right-triangle grids the
stiffness is the 5-point stencil and the lumped-load solution is the FDM exact discrete one;
linear fields are reproduced on any mesh; the FDM model's solvers do the solving."""
import math

import numpy as np
import pytest
from ulp import assert_ulp

from refsim.models.fem.meshes import perturb_interior, rectangle_triangles
from refsim.models.fem.poisson import P1Poisson, solve
from refsim.models.grid_laplacian import GridLaplacian
from refsim.models.poisson_solvers import PoissonProblem, solve_problem

EPS = np.finfo(float).eps


def grid_mesh(n_points):
    nodes, tris = rectangle_triangles(n_points - 1, n_points - 1)
    laplacian = GridLaplacian((n_points,) * 2, (1.0 / (n_points - 1),) * 2,
                              (("dirichlet", "dirichlet"),) * 2)
    return P1Poisson(nodes, tris), nodes, laplacian


def sine(nodes):
    """u = sin(pi x) sin(pi y) and f = lap u = -2 pi^2 u at the nodes."""
    u = np.sin(np.pi * nodes[:, 0]) * np.sin(np.pi * nodes[:, 1])
    return u, -2.0 * np.pi ** 2 * u


@pytest.mark.parametrize("n_points", [5, 17, 33])
def test_on_right_triangles_the_stiffness_is_the_five_point_stencil(n_points):
    p1, nodes, laplacian = grid_mesh(n_points)
    h = 1.0 / (n_points - 1)
    free = laplacian.free.reshape(-1)  # node j (N) + i is grid point (j, i): the same order
    k = p1.stiffness()[free].toarray()
    stencil = -(h * h) * laplacian.matrix()[free].toarray()
    assert_ulp(k, stencil, 4, "A grad phi_a . grad phi_b through Dm^-1 of coordinates that "
               "linspace rounds: a few eps of the entries' scale 4", scale=4.0)
    # the p00 - p11 diagonal edges are in the pattern; their two triangles cancel, so only
    # the stencil's 5 entries per row are above round-off
    assert np.sum(np.abs(k) > 16 * EPS) == 5 * free.sum()


@pytest.mark.parametrize("method", ["direct", "cg"])
def test_the_lumped_load_solution_is_the_fdm_exact_discrete_solution(method):
    n_points = 17
    p1, nodes, laplacian = grid_mesh(n_points)
    h = 1.0 / (n_points - 1)
    u, f = sine(nodes)
    fixed = ~laplacian.free.reshape(-1)
    u_h, info = solve(p1.problem(f, fixed, np.zeros(len(u))), method, 1e-13)
    # u is the lowest eigenvector of the 5-point Laplacian: u_h = [pi^2 h^2 / (4 sin^2(pi h
    # / 2))] u exactly (docs/models.md#fdm-exact-discrete-poisson-solution)
    factor = (math.pi * h) ** 2 / (4.0 * math.sin(math.pi * h / 2) ** 2)
    # the solve's relative residual 1e-13, amplified by cond(-K_ff) <= 8 / (pi h)^2 = 208:
    # 2e-11 of |u| (direct: SuperLU's round-off cond x eps, far below)
    assert np.abs(u_h - factor * u).max() <= 208 * 1e-13
    fdm, _ = solve_problem(PoissonProblem((n_points,) * 2, (h, h), np.zeros((n_points,) * 2),
                                          f.reshape(n_points, n_points)), method, 1e-13)
    assert np.abs(u_h - fdm.reshape(-1)).max() <= 2 * 208 * 1e-13  # both within it
    assert info["residual"] <= 1e-13


def test_the_consistent_load_is_not_the_fdm_solution():
    p1, nodes, laplacian = grid_mesh(17)
    u, f = sine(nodes)
    fixed = ~laplacian.free.reshape(-1)
    lumped, _ = solve(p1.problem(f, fixed, np.zeros(len(u))))
    consistent, _ = solve(p1.problem(f, fixed, np.zeros(len(u)), load="consistent"))
    # M f spreads f over the neighbours: an O(h^2) error too, but another one (measured
    # max |difference| 0.0128 at N = 17, 1.3 % of max u)
    assert np.abs(consistent - lumped).max() > 1e-3
    assert np.abs(consistent - u).max() < 0.05


def test_a_linear_field_is_reproduced_on_an_irregular_mesh():
    nodes, tris = rectangle_triangles(6, 5, 1.2, 1.0)
    nodes = perturb_interior(nodes, 0.04, seed=31)
    p1 = P1Poisson(nodes, tris)
    exact = 0.3 + 2.0 * nodes[:, 0] - 1.5 * nodes[:, 1]  # harmonic: lap u = 0
    fixed = np.isclose(nodes[:, 0], 0) | np.isclose(nodes[:, 0], 1.2) | np.isclose(
        nodes[:, 1], 0) | np.isclose(nodes[:, 1], 1.0)
    guess = np.where(fixed, exact, 0.0)
    u_h, _ = solve(p1.problem(np.zeros(len(exact)), fixed, guess), "direct", 1e-14)
    # P1 holds linear fields exactly; the direct solve's round-off is cond x eps x |u|
    # (cond of a 30-node Laplacian ~ 50): 1e-12 leaves 20x
    assert np.abs(u_h - exact).max() <= 1e-12
    assert (~fixed).sum() == 20


def test_multigrid_is_refused_and_the_mass_integrates_one():
    p1, _, laplacian = grid_mesh(5)
    assert_ulp(p1.mass().sum(), 1.0, 32, "element areas / 12 summed in another order")
    assert_ulp(p1.lumped_areas().sum(), 1.0, 32, "element areas / 3 summed")
    with pytest.raises(ValueError, match="multigrid needs a grid"):
        solve(p1.problem(np.zeros(25), ~laplacian.free.reshape(-1), np.zeros(25)), "multigrid")
