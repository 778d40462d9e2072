"""taichi's Poisson solvers (issue 15): the 5-point (2D) / 7-point (3D) equation L_h u = f on
one `Grid` part whose sides are all Dirichlet, solved by float64 taichi kernels
(`refsim_adapters.taichi_engine.poisson_kernels`), following the Poisson contract shared with the
in-house group:
- scene: Grid(model="poisson", boundary="dirichlet", fields {"u": initial guess (Dirichlet
  values on the boundary), "f": right-hand side}, coefficients {"rtol": relative residual});
- integrator "steady": one step() is one complete solve from the scene's initial guess;
- observe: grid.u, grid.f, "residual" = ||f - L_h u||_2 / ||f||_2 over the free points (the
  true residual, recomputed after CG's recursive one has converged), "iterations".
Formulations: "cg", matrix-free conjugate gradient without preconditioner;
"mgpcg", CG preconditioned by one geometric multigrid cycle (vertex-centred grids of 2^k + 1
points a side; symmetric cycle: red-black Gauss-Seidel pre-sweeps red then black, post-sweeps
black then red, or damped Jacobi; full weighting = P^T / 2^d; d-linear prolongation; the
5-/7-point operator rediscretised at 2h on every level; coarsest level by symmetric Gauss-
Seidel sweeps). Solver options (PoissonSim keywords): levels, smoother, sweeps, cycle,
coarse_sweeps; all reported in settings().
"""
from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass

import numpy as np

from refsim.engine import EngineFailure, ModelGroup, Sim
from refsim.scene import Grid

INTEGRATORS = ("steady",)
FORMULATIONS = ("cg", "mgpcg")
SMOOTHERS = ("rbgs", "jacobi")
CYCLES = ("V", "W")
INTEGRATOR_INFO = {"name": "steady", "order": 0, "family": "static solve", "explicit": False,
                   "symplectic": False}
SOLVER_TEXT = {"cg": "conjugate gradient on A = -L_h (SPD), matrix-free, no preconditioner",
               "mgpcg": "conjugate gradient on A = -L_h preconditioned by one geometric "
                        "multigrid cycle per iteration (z = M r)"}


def multigrid_reason(shape) -> str | None:
    """Why a grid of `shape` has no vertex-centred hierarchy, None if it has one."""
    if any(n < 3 or (n - 1) & (n - 2) for n in shape):
        return f"multigrid needs 2^k + 1 points a side (k >= 1), got shape {tuple(shape)}"
    return None


def level_shapes(shape, levels: int) -> list[tuple]:
    """Shapes of the hierarchy, finest first: every axis halved ((n - 1) / 2 + 1) while the
    shortest side keeps >= 3 points; `levels` of them (0: all)."""
    shapes = [tuple(shape)]
    while min(shapes[-1]) >= 5 and (levels == 0 or len(shapes) < levels):
        shapes.append(tuple((n - 1) // 2 + 1 for n in shapes[-1]))
    return shapes


def claims(scene) -> bool:
    return any(g.model == "poisson" for g in scene.parts_of(Grid))


def scene_reason(scene) -> str | None:
    """Why the taichi Poisson group refuses a scene, None if it runs it."""
    grids = scene.parts_of(Grid)
    if len(grids) != 1 or scene.part_kinds() != {"grids"}:
        return "taichi Poisson: one grid alone per scene"
    grid = grids[0]
    if len(grid.shape) not in (2, 3):
        return f"taichi Poisson: 2D or 3D grids (5-/7-point stencil), got {len(grid.shape)}D"
    if any(side != "dirichlet" for pair in grid.boundary for side in pair):
        return f"taichi Poisson: every side Dirichlet, got {grid.boundary}"
    if set(grid.fields) != {"u", "f"}:
        return f"taichi Poisson: fields u (initial guess) and f (rhs), got {sorted(grid.fields)}"
    rtol = grid.coefficients.get("rtol")
    if rtol is None or not 0.0 < rtol < 1.0:
        return f"taichi Poisson: coefficient rtol must be in (0, 1), got {rtol}"
    return None


def supports(engine, scene, integrator):
    reason = scene_reason(scene)
    if reason is None and integrator is not None and integrator not in INTEGRATORS:
        reason = (f"taichi Poisson: a static solve, integrator must be one of "
                  f"{list(INTEGRATORS)}, got {integrator!r}")
    return reason


def formulations(engine, scene):
    """cg always; mgpcg where the grid is 2^k + 1 points a side (multigrid_reason)."""
    grids = scene.parts_of(Grid)
    grid = grids[0] if len(grids) == 1 else None
    if grid is None or multigrid_reason(grid.shape) is not None:
        return FORMULATIONS[:1]
    return FORMULATIONS


@dataclass(frozen=True)
class MultigridOptions:
    """levels: grids in the hierarchy (0: as many as halving allows, down to 3 points on the
    shortest side); smoother: "rbgs" (red-black Gauss-Seidel) or "jacobi" (damped, omega =
    2d / (2d + 1), the smoothing-optimal weight of the 5-/7-point Laplacian); sweeps: pre-
    and post-smoothing sweeps per level (equal: a symmetric cycle; 2 by default: measured,
    2D 1025^2 to rtol 1e-8 ties with 1 sweep (6 against 8 iterations, 0.39 s both) and 3D
    65^3 is 25 % faster (6 against 10 iterations)); cycle: "V" or "W" (W: 2^levels coarse
    visits, each a few kernel launches: slower on these grids, kept for comparison);
    coarse_sweeps: symmetric Gauss-Seidel sweeps on the coarsest level (0: enough to cut its
    error 1000-fold, ln(1000) (m + 1)^2 / pi^2 for m points on its longest side, GS's rate
    being cos^2(pi / (m + 1)))."""

    levels: int = 0
    smoother: str = "rbgs"
    sweeps: int = 2
    cycle: str = "V"
    coarse_sweeps: int = 0

    def __post_init__(self):
        for name, low in (("levels", 0), ("sweeps", 1), ("coarse_sweeps", 0)):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or value < low:
                raise ValueError(f"mgpcg {name} must be an integer >= {low}, got {value!r}")
        if self.smoother not in SMOOTHERS:
            raise ValueError(f"mgpcg smoother must be one of {list(SMOOTHERS)}, got "
                             f"{self.smoother!r}")
        if self.cycle not in CYCLES:
            raise ValueError(f"mgpcg cycle must be one of {list(CYCLES)}, got {self.cycle!r}")

    def resolved(self, shape) -> MultigridOptions:
        """Levels and coarse sweeps made explicit for a grid of `shape`."""
        most = len(level_shapes(shape, 0))
        if self.levels > most:
            raise ValueError(f"mgpcg levels must be in [1, {most}] for a grid of {shape} "
                             f"(0: all), got {self.levels}")
        levels = self.levels or most
        coarsest = level_shapes(shape, levels)[-1]
        sweeps = self.coarse_sweeps or math.ceil(math.log(1e3) * (max(coarsest) - 1) ** 2
                                                 / math.pi ** 2)
        return MultigridOptions(levels, self.smoother, self.sweeps, self.cycle, sweeps)


def iteration_cap(shape, spacing, rtol_from_start) -> int:
    """Twice CG's exact-arithmetic bound for ||r_k|| <= rtol' ||r_0||: with kappa = lam_max /
    lam_min of A on the free points (lam = sum_k (4 / h_k^2) sin^2 or cos^2 (pi / (2 (N_k -
    1)))), ||r_k|| / ||r_0|| <= 2 sqrt(kappa) exp(-2 k / sqrt(kappa)), so k = sqrt(kappa) / 2
    ln(2 sqrt(kappa) / rtol'). The factor 2 allows for finite-precision CG's delay; reaching
    the cap means the target sits below the round-off floor (a failure, not a result)."""
    theta = [math.pi / (2 * (n - 1)) for n in shape]
    low = sum(4 / h ** 2 * math.sin(t) ** 2 for h, t in zip(spacing, theta))
    high = sum(4 / h ** 2 * math.cos(t) ** 2 for h, t in zip(spacing, theta))
    root = math.sqrt(high / low)
    return 10 + 2 * math.ceil(root / 2 * math.log(2 * root / min(rtol_from_start, 1.0)))


class PoissonSim(Sim):
    """One Poisson solve per step, from the scene's initial guess (contract above)."""

    def __init__(self, grid, formulation="cg", options=None):
        from ..runtime import THREADS, effective_config, runtime
        if formulation not in FORMULATIONS:
            raise ValueError(f"taichi Poisson formulation must be one of {list(FORMULATIONS)},"
                             f" got {formulation!r}")
        self.dt, self.steps, self.formulation = 1.0, 0, formulation
        self.shape, self.spacing = tuple(grid.shape), tuple(grid.spacing)
        self.rtol = float(grid.coefficients["rtol"])
        self.options = None
        if formulation == "mgpcg":
            reason = multigrid_reason(self.shape)
            if reason:
                raise ValueError(f"taichi mgpcg: {reason}")
            self.options = (options or MultigridOptions()).resolved(self.shape)
        self.threads, self.config = THREADS, effective_config()
        self.u0 = np.array(grid.fields["u"], float)
        self.f = np.array(grid.fields["f"], float)
        rt = runtime()
        key = ("grid_poisson", len(self.shape), formulation,
               self.options.smoother if self.options else "")
        self.cold = key not in rt["compiled"]
        if self.cold:
            t0 = time.perf_counter()
            self._warm_up()
            self.compile_s = time.perf_counter() - t0
            rt["compiled"].add(key)
        self.solver = self._solver(self.shape, self.spacing, self.f, self.options)
        self.last = self.solver.start(self.u0)  # (iterations 0, residual of the guess)
        self.cap = iteration_cap(self.shape, self.spacing, self.solver.start_ratio(self.rtol))

    def _warm_up(self):
        """Compile every kernel this formulation launches: one solve of a 5^d problem (taichi
        compiles per array rank and dtype, not per shape, so the real grid reuses them)."""
        shape = (5,) * len(self.shape)
        options = None if self.options is None else MultigridOptions(
            0, self.options.smoother, 1, self.options.cycle, 1).resolved(shape)
        tiny = self._solver(shape, (0.25,) * len(shape), np.ones(shape), options)
        tiny.solve(np.zeros(shape), 1e-3, 100)

    @staticmethod
    def _solver(shape, spacing, f, options):
        from ..poisson_kernels import PoissonSolver
        shapes = level_shapes(shape, options.levels) if options is not None else ()
        return PoissonSolver(shape, spacing, f, options, shapes)

    def _step_impl(self, n):
        for _ in range(n):
            self.last = self.solver.solve(self.u0, self.rtol, self.cap)
            if self.last[1] > self.rtol:
                raise EngineFailure(
                    f"taichi {self.formulation}: relative residual {self.last[1]:.3g} above "
                    f"rtol {self.rtol:g} after {self.last[0]} iterations (cap {self.cap}): "
                    "the target is below float64's round-off floor for this grid")

    def _observe(self):
        return {"grid.u": self.solver.solution(), "grid.f": self.f.copy(),
                "residual": float(self.last[1]), "iterations": int(self.last[0])}

    def settings(self):
        solver = {"formulation": self.formulation, "solver": SOLVER_TEXT[self.formulation],
                  "rtol": self.rtol, "max_iterations": self.cap,
                  "stop": "recursive CG residual <= rtol ||f||, then the true residual "
                          "recomputed; CG restarted from the current u if it is above",
                  "residual": "||f - L_h u||_2 / ||f||_2 over the free points (||r_0|| of "
                              "the initial guess in place of ||f|| where f = 0 there)",
                  "kernels": "float64 taichi kernels: stencil apply fused with p.Ap, u and r "
                             "updates fused with r.r, reductions in the kernels"}
        if self.options is not None:
            solver.update(multigrid=self._multigrid_settings())
        return {"integrator": dict(INTEGRATOR_INFO), "dtype": "float64", "f64": True,
                "threads": self.threads, **self.config, **solver,
                "model": f"L_h u = f, {2 * len(self.shape) + 1}-point stencil, "
                         f"shape {list(self.shape)}, spacing {list(self.spacing)}, "
                         "every side Dirichlet (u0's boundary values)",
                "points": int(np.prod(self.shape)),
                "arrays": "taichi ndarrays (u copied in from the initial guess per solve, "
                          "observed by to_numpy)",
                "compile": "cold JIT in this build (one 5^d solve)" if self.cold else
                "kernels already compiled in this process"}

    def _multigrid_settings(self):
        opts = self.options
        d = len(self.shape)
        smoother = ("red-black Gauss-Seidel (pre: red then black; post: black then red)"
                    if opts.smoother == "rbgs" else
                    f"damped Jacobi, omega = 2d/(2d+1) = {2 * d / (2 * d + 1):.6g}")
        return {**asdict(opts), "smoother_text": smoother,
                "level_shapes": [list(s) for s in level_shapes(self.shape, opts.levels)],
                "restriction": "full weighting, P^T / 2^d",
                "prolongation": "d-linear interpolation",
                "coarse_operator": "the 5-/7-point stencil rediscretised at each level's "
                                   "spacing (not Galerkin)",
                "coarse_solve": f"{opts.coarse_sweeps} red-black then {opts.coarse_sweeps} "
                                "black-red Gauss-Seidel sweeps (symmetric)",
                "symmetric": "yes: post-smoother the adjoint of the pre-smoother, restriction "
                             "proportional to P^T, symmetric coarse solve (CG stays valid)"}


def build(engine, scene, dt, integrator, formulation):
    return PoissonSim(scene.parts_of(Grid)[0], formulation or FORMULATIONS[0])


MODEL_GROUP = ModelGroup(name="grid_poisson", build=build, claims=claims,
                         parts=frozenset({"grids"}), features=frozenset({"grid", "poisson"}),
                         supports=supports, formulations=formulations, integrators=INTEGRATORS)
