"""P1 finite elements for the Poisson equation lap u = f on a triangle mesh with Dirichlet
values on marked nodes (slide 000's weak form; the sign convention of deck 001 and the FDM
model, docs/models.md#fdm-laplacian-and-poisson), solved by the FDM model's solvers.

Weak form: find u_h = sum_j u_j phi_j with sum_j k_ij u_j = -int f phi_i for every free node
i, where k_ij = int grad phi_j . grad phi_i (the stiffness; per triangle of area A,
A grad phi_a . grad phi_b, assembled on a pattern found once: refsim.models.fem.assembly)
and the load is lumped: int f phi_i ~ f_i A_i, A_i = sum of A / 3 over the triangles at node i
(the consistent load int f phi_i = sum_j M_ij f_j is `consistent_load`). Slide 000's
integration by parts has a sign slip; the weak form it ends on is the one above.

On a grid of square cells h x h split into right triangles along one diagonal, k is exactly
the 5-point stencil: 4 on the diagonal, -1 for the four axis neighbours, 0 for the two
diagonal ones (the two triangles at a diagonal edge cancel), i.e. K = -h^2 L_h; and the lumped
load is f_i h^2. The P1 system is then h^2 times the FDM one, so its solution is the FDM
exact discrete solution (refsim.models.poisson_solvers); the consistent load is not.

`P1Poisson.problem(f, fixed, values)` returns a problem with the interface of
refsim.models.poisson_solvers.PoissonProblem (`system()` -> (A, b) with A = -K_ff negative
definite as L_h is, b = A_i f_i + K_fb u_b; `u0`, `free`, `rhs_norm`, `residual`, `full`), and
`solve(problem, method, rtol)` hands it to `poisson_solvers.solve_problem` ("direct": SuperLU,
"cg", "pyamg"); the geometric multigrid needs a grid and is refused.
"""
from __future__ import annotations

import numpy as np

from .assembly import BlockPattern
from .elements import Elements
from ..poisson_solvers import solve_problem

METHODS = ("direct", "cg", "pyamg")


class P1Poisson:
    """nodes (n, 2) or (n, 3) with z = 0; triangles (m, 3) counter-clockwise."""

    def __init__(self, nodes, triangles):
        nodes = np.asarray(nodes, float)
        self.elements = Elements(nodes[:, :2], triangles)
        self.pattern = BlockPattern(self.elements.cells, self.elements.n, 1)
        self._stiffness = None

    def stiffness(self):
        """K (n, n) CSR: k_ij = int grad phi_j . grad phi_i."""
        if self._stiffness is None:
            g = self.elements.grad
            blocks = self.elements.volume[:, None, None] * (g @ np.swapaxes(g, 1, 2))
            self._stiffness = self.pattern.matrix(blocks)
        return self._stiffness

    def lumped_areas(self):
        """(n,) A_i = sum of A / 3 over the triangles at node i."""
        share = np.repeat(self.elements.volume / 3.0, 3)
        return np.asarray(self.elements.scatter @ share).reshape(-1)

    def mass(self):
        """Consistent mass M_ij = int phi_i phi_j (CSR)."""
        local = (np.ones((3, 3)) + np.eye(3)) / 12.0
        return self.pattern.matrix(self.elements.volume[:, None, None] * local)

    def consistent_load(self, f):
        return self.mass() @ np.asarray(f, float)

    def problem(self, f, fixed, values, load="lumped") -> P1Problem:
        """The Dirichlet problem: f (n,) at the nodes, fixed (n,) bool, values (n,) (used on
        the fixed nodes, and as the initial guess elsewhere); load "lumped" or "consistent"."""
        if load not in ("lumped", "consistent"):
            raise ValueError(f"poisson load must be 'lumped' or 'consistent', got {load!r}")
        f = np.asarray(f, float)
        weighted = self.lumped_areas() * f if load == "lumped" else self.consistent_load(f)
        return P1Problem(self.stiffness(), weighted, np.asarray(fixed, bool), values)


class P1Problem:
    """The free-node system (-K_ff) u_f = A f + K_fb u_b in PoissonProblem's interface."""

    shape = None  # no grid: the geometric multigrid does not apply

    def __init__(self, k, weighted_load, fixed, values):
        self.free = ~fixed
        if not self.free.any():
            raise ValueError("poisson fixed nodes must leave at least one free node")
        self.u0 = np.array(values, float)
        kf = k[self.free]
        boundary = np.where(self.free, 0.0, self.u0)
        self.a = -kf[:, self.free].tocsr()
        self.b = weighted_load[self.free] + kf @ boundary
        self.rhs_norm = float(np.linalg.norm(self.b)) or 1.0

    def system(self):
        return self.a, self.b

    def residual(self, u) -> float:
        """||b - A u_f||_2 / ||b||_2."""
        return float(np.linalg.norm(self.b - self.a @ u[self.free])) / self.rhs_norm

    def full(self, x):
        u = self.u0.copy()
        u[self.free] = x
        return u


def solve(problem: P1Problem, method="direct", rtol=1e-12, options=None):
    """(u (n,), info) by the FDM model's solver `method` (one of METHODS), stopped at
    ||b - A u||_2 <= rtol ||b||_2."""
    if method not in METHODS:
        raise ValueError(f"P1 poisson method must be one of {list(METHODS)} (multigrid needs "
                         f"a grid), got {method!r}")
    return solve_problem(problem, method, rtol, options)
