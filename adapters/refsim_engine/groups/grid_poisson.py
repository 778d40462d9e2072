"""The in-house engine's Poisson group (slide 001: the 5-point, in 3D 7-point, Poisson
equation): L_h u = f on the free points of one all-Dirichlet `Grid` of model "poisson"
(refsim.models.poisson_solvers), 1D to 3D.

Scene contract (shared with the taichi group): fields "u" (boundary values on the boundary,
the initial guess inside) and "f" (right-hand side at every point), coefficient "rtol" (the
relative residual target ||f - L_h u||_2 / ||f||_2 over the free points, in (0, 1)). One
integrator, "steady": no time stepping, one `step()` is one complete solve from the scene's
initial guess, solver setup included (each step re-solves from it, so a timing pass of fresh
Sims times the whole solve). Formulations (named alternatives of one model): "direct" (SuperLU, the default),
"cg" (no preconditioner), "multigrid" (in-house geometric multigrid, 2^k + 1 points per axis),
"pyamg" (smoothed aggregation, CG-accelerated), and on a 2D grid of square cells "p1": the
P1 finite-element Poisson of the FEM group (refsim.models.fem.poisson, slide 000's weak form)
on the grid's points as nodes, each cell split into two right triangles along its lower-left
to upper-right diagonal, lumped load, SuperLU: its stiffness is h^2 times the 5-point stencil,
so it solves the same discrete system and meets the same exact discrete solution (the FEM
issue's case 8, run through the FDM case).

Observes "grid.u" (the solution, the grid's shape), "grid.f" (the rhs, unchanged), "residual"
(the relative residual of the last solve, recomputed by the slice stencil; that of the initial
guess before any step) and "iterations" (iterations or cycles of the last solve; 1 for direct;
0 before any step).
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup, Sim
from refsim.models.multigrid import multigrid_reason
from refsim.models.poisson_solvers import (DEFAULT_OPTIONS, METHODS, PoissonProblem,
                                           dirichlet_reason, solve_problem)
from refsim.scene import Grid

INTEGRATORS = ("steady",)
STEADY = {"name": "steady", "order": 0, "family": "static solve", "explicit": False,
          "symplectic": False}
SOLVER_TEXT = {
    "direct": "scipy.sparse.linalg.splu (SuperLU) of the free-point matrix -A, symmetric "
              "mode: MMD_AT_PLUS_A ordering, diag_pivot_thresh 0",
    "cg": "scipy.sparse.linalg.cg on -A (SPD), no preconditioner",
    "multigrid": "in-house geometric multigrid (refsim.models.multigrid)",
    "pyamg": "pyamg.smoothed_aggregation_solver(-A).solve(-b, accel='cg') (defaults)",
    "p1": "P1 finite elements on the grid's points (two right triangles a cell, lower-left "
          "to upper-right diagonal), k_ij = int grad phi_j . grad phi_i, lumped load A_i f_i; "
          "scipy.sparse.linalg.splu (SuperLU) of -K_ff (refsim.models.fem.poisson)",
}


def claims(scene) -> bool:
    return len(scene.parts_of(Grid)) == 1 and scene.parts_of(Grid)[0].model == "poisson"


def supports(engine, scene, integrator):
    if scene.part_kinds() != {"grids"}:
        return (f"refsim poisson: a grid alone, got also "
                f"{', '.join(sorted(scene.part_kinds() - {'grids'}))}")
    grid = scene.part(Grid)
    reason = dirichlet_reason(grid)
    if reason:
        return f"refsim {reason}"
    rtol = grid.coefficients.get("rtol")
    if rtol is None or not 0.0 < rtol < 1.0:
        return f"refsim poisson: coefficient rtol in (0, 1) required, got {rtol}"
    return None


def p1_reason(grid) -> str | None:
    """Why the P1 formulation does not apply to `grid` (None where it does)."""
    if len(grid.shape) != 2 or grid.spacing[0] != grid.spacing[1]:
        return (f"refsim poisson formulation 'p1': a 2D grid of square cells, got "
                f"{len(grid.shape)}D with spacing {grid.spacing}")
    return None


def formulations(engine, scene):
    grid = scene.part(Grid)
    return METHODS + (("p1",) if grid is not None and p1_reason(grid) is None else ())


class P1Grid:
    """The grid's points as P1 nodes (grid point (a, b) is node a n_1 + b: C order), each cell
    split into the right triangles of refsim.models.fem.meshes.rectangle_triangles (whose node
    j (nx + 1) + i is grid point (j, i)); lumped load, solved by SuperLU."""

    def __init__(self, grid):
        from refsim.models.fem.meshes import rectangle_triangles
        from refsim.models.fem.poisson import P1Poisson
        n0, n1 = grid.shape
        h = grid.spacing[0]
        nodes, tris = rectangle_triangles(n1 - 1, n0 - 1, (n1 - 1) * h, (n0 - 1) * h)
        self.grid, self.p1 = grid, P1Poisson(nodes, tris)
        self.fixed = ~PoissonProblem.of(grid).free.reshape(-1)

    def solve(self, rtol):
        from refsim.models.fem.poisson import solve
        u0 = np.asarray(self.grid.fields["u"], float).reshape(-1)
        f = np.asarray(self.grid.fields["f"], float).reshape(-1)
        u, info = solve(self.p1.problem(f, self.fixed, u0), "direct", rtol)
        return u.reshape(self.grid.shape), info


class PoissonSim(Sim):
    """One Dirichlet Poisson problem, solved afresh from the initial guess at every step."""

    def __init__(self, grid, dt, method):
        if method == "p1" and p1_reason(grid):
            raise ValueError(p1_reason(grid))
        if method == "multigrid" and multigrid_reason(grid.shape):
            raise ValueError(f"refsim poisson variant 'multigrid': "
                             f"{multigrid_reason(grid.shape)}; use direct, cg or pyamg")
        self.dt, self.grid, self.method = float(dt), grid, method
        self.rtol = float(grid.coefficients["rtol"])
        self.options = dict(DEFAULT_OPTIONS) if method == "multigrid" else {}
        self.problem = PoissonProblem.of(grid)
        self.u = self.problem.u0.copy()
        self.iterations = 0
        self.residual = self.problem.residual(self.u)

    def _step_impl(self, n):
        for _ in range(n):  # every step the same complete solve from the initial guess
            if self.method == "p1":  # its residual is the P1 system's: report L_h's
                self.u, info = P1Grid(self.grid).solve(self.rtol)
                info = {**info, "residual": self.problem.residual(self.u)}
            else:
                problem = PoissonProblem.of(self.grid)
                self.u, info = solve_problem(problem, self.method, self.rtol,
                                             dict(self.options))
            self.iterations, self.residual = info["iterations"], info["residual"]

    def _observe(self):
        return {"grid.u": self.u.copy(), "grid.f": self.problem.f.copy(),
                "residual": float(self.residual), "iterations": int(self.iterations)}

    def settings(self):
        out = {"integrator": dict(STEADY), "dtype": "float64", "threads": 1,
               "solver": self.method, "solver_text": SOLVER_TEXT[self.method],
               "rtol": self.rtol, "criterion": "||f - L_h u||_2 <= rtol ||f||_2 on the free "
               "points, checked on the true residual (restart if the recurrence's drifted)",
               "points": list(self.grid.shape), "unknowns": int(self.problem.free.sum()),
               "model": self.problem.laplacian.describe(),
               "step": "one complete solve from the initial guess (setup included)"}
        if self.method == "multigrid":
            from refsim.models.multigrid import GeometricMultigrid
            mg = GeometricMultigrid(self.grid.shape, self.grid.spacing, self.options["pre"],
                                    self.options["post"])
            out.update(multigrid_mode=self.options["mode"],
                       multigrid_use=("preconditioner of CG (MGPCG), one symmetric V-cycle "
                                      "per iteration" if self.options["mode"] == "pcg"
                                      else "solver: V-cycles until the residual target"),
                       multigrid=mg.describe())
        if self.method == "pyamg":
            out["pyamg"] = {"strength": "symmetric", "aggregate": "standard",
                            "smooth": "jacobi omega 4/3", "smoother": "symmetric block "
                            "Gauss-Seidel pre and post", "cycle": "V", "accel": "cg",
                            "max_coarse": 10, "max_levels": 10}
        return out


def build(engine, scene, dt, integrator, formulation):
    return PoissonSim(scene.part(Grid), dt, formulation or METHODS[0])


MODEL_GROUP = ModelGroup(name="grid_poisson", build=build, claims=claims,
                         parts=frozenset({"grids"}), features=frozenset({"grid", "poisson"}),
                         supports=supports, formulations=formulations, integrators=INTEGRATORS)
