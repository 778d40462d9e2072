"""The 5-point (3D: 7-point) Poisson equation with a manufactured solution (slide 001;
docs/models.md#fdm-exact-discrete-poisson-solution): u = sin(pi x) sin(pi y) on the unit square
(3D: times sin(pi z) on the unit cube), f = lap u = -d pi^2 u, u = 0 on the boundary, N points
a side, h = 1 / (N - 1).

Exact discrete solution. u is an eigenvector of the discrete Laplacian: per axis the 3-point
second difference of sin(pi x_j) is -(4 / h^2) sin^2(pi h / 2) sin(pi x_j) (GridLaplacian's
`mode_eigenvalue`, theta = pi h), so L_h u = -lambda_min u with lambda_min = d (4 / h^2)
sin^2(pi h / 2), the smallest eigenvalue of -L_h, in 2D and 3D alike. Hence
u_h = L_h^{-1} f = (d pi^2 / lambda_min) u = [pi^2 h^2 / (4 sin^2(pi h / 2))] u exactly,
the same factor in every dimension (the d cancels). It is the reference: the error against it
is the solver's alone.

Compared observable `u` (dimensionless); err_max etc. are the 2-norm over grid points of
u - u_h (at t = 0 the reference is the initial guess, so that row of the series is 0). The
column the bound judges is `err_residual` = ||L_h (u - u_h)||_2 / ||f||_2 over the free
points, the error in the L_h norm: since L_h u_h = f it is the solve's TRUE relative residual,
which every solver stops at or below rtol, so the bound is rtol itself plus rounding (tight up
to the solver's last iteration's overshoot, 1 / its contraction). The 2-norm error obeys only
||e||_2 <= ||r||_2 / lambda_min, attained where the residual is the lowest mode; a multigrid
or Krylov residual is mostly high modes, so that bound was 70-700 x the measured errors.
Columns beyond the errors: `residual` and `iterations` as the solver reports them, and
`err_continuum` = max |u - u_exact| (the O(h^2) space error, = (factor - 1) max|u| up to the
solver's error). One "step" of pseudo-time is one complete solve: t_end = dt = 1,
no order in dt (order_meaningful False), no energy.

Note: f is one eigenvector, so unpreconditioned CG from the zero guess converges in ONE
iteration (the Krylov space of an eigenvector is its span). The `solution = "polynomial"`
variants (`poly_2d`, `poly_2d_1025`; `refsim bench fdm` times the solvers on them) use
u = prod 4 x (1 - x) instead, quadratic in each variable, on which the 3-point second
difference is exact: u_h = u exactly, and f = sum_a -8 prod_(b != a) 4 x_b (1 - x_b) holds
every odd mode, so each solver does its real work.
"""
from __future__ import annotations

import math

import numpy as np

from refsim.case import EPS, Param, SteadyCase
from refsim.models.grid_laplacian import GridLaplacian
from refsim.models.multigrid import multigrid_reason
from refsim.scene import Grid, Scene


def discrete_factor(h: float) -> float:
    """pi^2 h^2 / (4 sin^2(pi h / 2)): u_h / u for the 3-/5-/7-point Laplacian (> 1)."""
    return (math.pi * h) ** 2 / (4.0 * math.sin(0.5 * math.pi * h) ** 2)


def lambda_min(dim: int, h: float) -> float:
    """Smallest eigenvalue of -L_h with Dirichlet sides: d (4 / h^2) sin^2(pi h / 2)."""
    return dim * 4.0 / h ** 2 * math.sin(0.5 * math.pi * h) ** 2


class PoissonManufactured(SteadyCase):
    name = "poisson_manufactured"
    description = ("5-/7-point Poisson with u = sin(pi x) sin(pi y) (3D: sin(pi z)): exact "
                   "discrete solution [pi^2 h^2 / (4 sin^2(pi h/2))] u; solver error and "
                   "residual by formulation")
    tags = ("fdm", "poisson", "exact", "steady")
    observable, units = "u", "1"
    params = {
        "dim": Param(2, 2, 3, "spatial dimension (2: unit square, 3: unit cube)"),
        "points": Param(65, 5, 4097, "points a side N (2^k + 1 for multigrid), h = 1/(N-1)"),
        "rtol": Param(1e-8, 1e-12, 0.1, "relative residual target of the solvers (below "
                      "1e-12 the residual of a double-precision solve is round-off: "
                      "(2d+1) eps lambda_max ||u|| / ||f|| ~ 1e-13 at N = 65)"),
        "solution": Param("sine", choices=("sine", "polynomial")),
    }
    variants = {"2d": {}, "3d": {"dim": 3, "points": 17}, "3d_33": {"dim": 3, "points": 33},
                "2d_257": {"points": 257}, "2d_1025": {"points": 1025},
                "3d_65": {"dim": 3, "points": 65},
                "poly_2d": {"solution": "polynomial"},
                "poly_2d_1025": {"solution": "polynomial", "points": 1025}}
    default_variants = quick_variants = ("2d", "poly_2d")
    tolerance_norm = "err_residual"  # the error in the L_h norm, relative (module doc)

    # -- grid and fields ----------------------------------------------------------------------
    @staticmethod
    def dims(p) -> tuple[int, int, float]:
        dim, n = int(p["dim"]), int(p["points"])
        if dim != p["dim"] or n != p["points"] or multigrid_reason((n,)):
            raise ValueError(f"poisson_manufactured: dim must be 2 or 3 and points an integer "
                             f"2^k + 1 (multigrid is a formulation), got {p['dim']}, "
                             f"{p['points']}")
        return dim, n, 1.0 / (n - 1)

    def _line(self, p) -> np.ndarray:
        """One axis' factor: sin(pi x), or 4 x (1 - x) for the polynomial."""
        x = np.linspace(0.0, 1.0, self.dims(p)[1])
        if p["solution"] == "polynomial":
            return 4.0 * x * (1.0 - x)
        s = np.sin(np.pi * x)
        s[[0, -1]] = 0.0  # sin(pi) is 1.2e-16 in floating point: the boundary value is 0
        return s

    def continuum(self, p) -> np.ndarray:
        """sin(pi x) sin(pi y) (sin(pi z)), or prod 4 x (1 - x), at the grid points."""
        line, out = self._line(p), self._line(p)
        for _ in range(self.dims(p)[0] - 1):
            out = np.multiply.outer(out, line)
        return out

    def source(self, p) -> np.ndarray:
        """f = lap u: -d pi^2 u (sine), sum_a -8 prod_(b != a) 4 x_b (1 - x_b) (polynomial)."""
        dim, n, _ = self.dims(p)
        if p["solution"] == "sine":
            return -dim * np.pi ** 2 * self.continuum(p)
        line = self._line(p)
        out = np.zeros((n,) * dim)
        for axis in range(dim):  # d terms, each a whole-array outer product
            factors = [np.full(n, -8.0) if b == axis else line for b in range(dim)]
            term = factors[0]
            for f in factors[1:]:
                term = np.multiply.outer(term, f)
            out += term
        return out

    def exact_discrete(self, p) -> np.ndarray:
        factor = 1.0 if p["solution"] == "polynomial" else discrete_factor(self.dims(p)[2])
        return factor * self.continuum(p)

    def scene(self, p):
        dim, n, h = self.dims(p)
        u = self.continuum(p)
        grid = Grid(shape=(n,) * dim, spacing=h, model="poisson", boundary="dirichlet",
                    fields={"u": np.zeros_like(u), "f": self.source(p)},
                    coefficients={"rtol": p["rtol"]})
        return Scene(parts=(grid,), gravity=(0.0, 0.0, 0.0))

    def bodies(self, p):
        return int(p["points"]) ** int(p["dim"])

    # -- observables and reference ------------------------------------------------------------
    def observables(self, p, obs):
        return {"u": np.asarray(obs["grid.u"], float),
                "residual": np.asarray(obs["residual"], float),
                "iterations": np.asarray(obs["iterations"], float)}

    def reference(self, p, t):
        """The initial guess (zero) before the solve, u_h after it."""
        solved = np.asarray(t, float) >= 1.0 - 1e-12
        exact = self.exact_discrete(p)
        return {"u": np.where(solved.reshape((-1,) + (1,) * exact.ndim), exact, 0.0)}

    def motion_scale(self, p):
        """1: the zero guess's err_residual (||L_h u_h|| = ||f||), the tolerance column's
        scale."""
        return 1.0

    def solution_norm(self, p) -> float:
        """||u_h||_2 over the grid points (the err_* columns' scale)."""
        return float(np.linalg.norm(self.exact_discrete(p)))

    def _laplacian(self, p) -> GridLaplacian:
        dim, n, h = self.dims(p)
        return GridLaplacian((n,) * dim, (h,) * dim, (("dirichlet", "dirichlet"),) * dim)

    def rhs_norm(self, p) -> float:
        """||f||_2 over the free points (the solvers' criterion's scale)."""
        inner = (slice(1, -1),) * self.dims(p)[0]
        return float(np.linalg.norm(self.source(p)[inner]))

    def residual_error(self, p, u) -> float:
        """||L_h (u - u_h)||_2 / ||f||_2 over the free points: the error in the L_h norm,
        relative; = the true relative residual ||f - L_h u|| / ||f|| up to u_h's rounding."""
        return float(np.linalg.norm(self._laplacian(p).apply(u - self.exact_discrete(p)))
                     / self.rhs_norm(p))

    def evaluation_roundoff(self, p) -> tuple[float, str]:
        """(bound, reason) of the rounding in err_residual, relative to ||f||."""
        dim, _, h = self.dims(p)
        lam_max = 4.0 * dim / h ** 2
        stencil = 2 * (2 * dim + 1) * EPS * lam_max * self.solution_norm(p)
        reference = lam_max * self.reference_roundoff(p)
        bound = (stencil + reference) / self.rhs_norm(p)
        return bound, (
            f"the stencil's rounding, twice (the solver's check and this metric), (2d+1) eps "
            f"(4d/h^2) ||u_h||_2 each, plus u_h's rounding (below) through L_h, at most "
            f"4d/h^2 times it, over ||f||_2: {bound:.3g}")

    def reference_roundoff(self, p) -> float:
        """||fl(u_h) - u_h||_2: |fl(sin(pi x_j)) - sin(pi x_j)| <= (2 pi + 1) eps per factor
        (x_j and pi x_j rounded, sin's own ulp), d factors and d products: delta s <= d
        (2 pi + 2) eps a point, ||delta s||_2 <= 2^(d/2) d (2 pi + 2) eps ||s||_2 (||s||_2 =
        2^(-d/2) sqrt(points)); it reaches the solution and the reference by at most that
        each, and the factor's product one eps more."""
        dim = self.dims(p)[0]
        return (2 * 2 ** (dim / 2) * dim * (2 * math.pi + 2) + 1) * EPS * self.solution_norm(p)

    def error_floor(self, p) -> float:
        """err_residual's own rounding (evaluation_roundoff): below it, round-off."""
        return self.evaluation_roundoff(p)[0]

    def error_ceiling(self, p) -> float:
        return 0.1

    def extra_metrics(self, p, obs, observed, reference):
        u = observed["u"][-1]
        return {"residual": float(observed["residual"][-1]),
                "err_residual": self.residual_error(p, u),
                "iterations": int(observed["iterations"][-1]),
                "err_continuum": float(np.max(np.abs(u - self.continuum(p))))}

    # -- tolerance ----------------------------------------------------------------------------
    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        """rtol (the solvers' stopping criterion on the true residual) plus rounding."""
        roundoff, why = self.evaluation_roundoff(p)
        return p["rtol"] + roundoff, (
            f"err_residual = ||L_h (u - u_h)||_2 / ||f||_2 is the solve's true relative "
            f"residual ||f - L_h u||_2 / ||f||_2 (L_h u_h = f), which every formulation stops "
            f"at or below rtol = {p['rtol']:g} (checked on the true residual, restarting "
            f"where the recurrence's drifted): the bound is rtol itself; plus {why}")

CASE = PoissonManufactured()
