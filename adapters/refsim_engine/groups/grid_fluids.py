"""The in-house engine's grid-fluid group (issue 27; slides 001/000): incompressible
Navier-Stokes on one `FluidGrid` (a 2D MAC grid; refsim.models.grid_fluid), alone in a 2D scene.

Two ways to run it, chosen by the scene:
- `scene.meta["solve"] == "projection"` offers only "steady": one `step()` is one pressure
  projection of the scene's initial field (the same projection every step: the matrix, its
  factorisation or AMG hierarchy built once when the Sim is built), observed after it;
- any other scene offers the schemes "sl_linear", "sl_cubic", "sl_cubic_clamped", each with an
  optional backtrace ":euler", ":rk2" (the default) or ":rk3" (refsim.integrators.
  semi_lagrangian: names and orders): a step advects (semi-Lagrangian), adds the body force
  (the scene's gravity where the part asks), applies viscosity (the part's viscosity_scheme,
  explicit or implicit) and projects.
Formulations: the projection's solver, "direct" (SuperLU, the default), "cg", "pyamg",
"multigrid" (MGPCG, where the grid is all fluid with even cell counts), each to the part's
rtol on the true relative residual; a projection that does not reach it is an
engine failure (status `failed`).

Observes "grid.u" (nx + 1, ny), "grid.v" (nx, ny + 1) (m/s), "grid.p" (nx, ny) (kinematic
pressure of the last projection, m^2/s^2), and the extras "divergence" (max |D u| over the
fluid cells, 1/s), "residual" (the last projection's relative residual) and "iterations".
"""
from __future__ import annotations

import numpy as np

from refsim_adapters.common.grid_fluids import claims, integrator_reason, scene_reason
from refsim.engine import EngineFailure, ModelGroup, Sim
from refsim.integrators.semi_lagrangian import SCHEMES, scheme_info
from refsim.models.grid_fluid.projection import ALL_METHODS, METHODS
from refsim.models.grid_fluid.projection_mg import multigrid_reason
from refsim.models.grid_fluid.solver import FluidSolver
from refsim.scene import FluidGrid

STEADY = {"name": "steady", "order": 0, "family": "one pressure projection", "explicit": False,
          "symplectic": False}
INTEGRATORS = SCHEMES + ("steady",)
FEATURES = frozenset({"fluid_grid", "viscosity", "gravity", "free_surface", "solid_cells"})


def supports(engine, scene, integrator):
    return (scene_reason(scene, "refsim grid fluids")
            or integrator_reason(scene, integrator, "refsim grid fluids"))


def formulations(engine, scene):
    """The projection solvers; "multigrid" where its hierarchy applies (fluid cells only, even
    counts)."""
    part = scene.part(FluidGrid)
    return METHODS if multigrid_reason(part.shape, part.marks) else ALL_METHODS


class FluidSim(Sim):
    """A FluidSolver stepped by dt (or, for "steady", one projection of the initial field per
    step)."""

    failures = (EngineFailure,)

    def __init__(self, scene, dt, integrator, method):
        self.dt, self.part = float(dt), scene.part(FluidGrid)
        self.steady = integrator == "steady"
        self.scheme = "sl_linear" if self.steady else integrator
        self.solver = FluidSolver(self.part, self.scheme, method, scene.gravity[:2])
        self.iterations = 0

    def _check(self):
        info = self.solver.info
        if not info["residual"] <= self.solver.rtol:
            raise EngineFailure(f"projection ({self.solver.method}) stopped at relative "
                                f"residual {info['residual']:.3g} > rtol {self.solver.rtol:g}")

    def _step_impl(self, n):
        for _ in range(n):
            if self.steady:
                self.solver.u = np.array(self.part.u, float)
                self.solver.v = np.array(self.part.v, float)
                self.solver.project_only(self.dt)
            else:
                self.solver.step(self.dt)
            self._check()

    def _observe(self):
        s = self.solver
        return {"grid.u": s.u.copy(), "grid.v": s.v.copy(), "grid.p": s.p.copy(),
                "divergence": float(s.info["divergence"]),
                "residual": float(s.info["residual"]), "iterations": int(s.info["iterations"])}

    def settings(self):
        integrator = dict(STEADY) if self.steady else scheme_info(self.scheme)
        described = self.solver.describe()
        if self.steady:
            described = {k: described[k] for k in ("projection", "cells", "h", "sides")}
            described["step"] = ("one projection of the scene's initial field (matrix, "
                                 "factorisation or hierarchy built once at build)")
        return {"integrator": integrator, "dtype": "float64", "threads": 1,
                "vectorised": "numpy over all faces and cells; scipy.sparse solves",
                **described}


def build(engine, scene, dt, integrator, formulation):
    return FluidSim(scene, dt, integrator, formulation or METHODS[0])


MODEL_GROUP = ModelGroup(name="grid_fluids", build=build, claims=claims,
                         parts=None, features=FEATURES,  # supports names other parts
                         supports=supports, formulations=formulations, integrators=INTEGRATORS)
