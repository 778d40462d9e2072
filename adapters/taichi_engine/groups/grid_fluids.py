"""taichi's grid-fluid group (issue 27): incompressible Navier-Stokes on one `FluidGrid` (a 2D
MAC grid, refsim.models.grid_fluid's conventions), alone in a 2D scene, written as float64
taichi kernels to refsim's specification (refsim's in-house group, adapters/refsim_engine/
groups/grid_fluids.py, is the model), so the two agree to round-off or to the solver's
tolerance:
- the step (refsim.models.grid_fluid.solver.FluidSolver.step, operator splitting): semi-
  Lagrangian advection of u and v (refsim_adapters.taichi_engine.fluid_kernels: the same
  ghost layers, index coordinates, backtraces euler / rk2 / rk3 (Ralston) through the bilinear
  velocity, interpolants linear / cubic (Catmull-Rom) / cubic_clamped, operation for
  operation: bit-identical to refsim's numpy, tested), the body force (the scene's gravity
  where the part asks), viscosity (explicit: a kernel sweep; implicit: backward Euler by
  ti.linalg.SparseSolver, fluid_solvers), walls and solid faces set to 0, periodic duplicates
  copied, and the projection;
- the projection (fluid_solvers.PressureSolver), refsim's stopping rule ||b - A p|| <= rtol
  ||b|| on the true residual, the mean removed where there is no air; a projection above the
  part's rtol is an engine failure. Formulations: "direct" (A = G^T G assembled by a kernel,
  taichi's SparseSolver LDLT, pattern analysed and factorised once per Sim, one cell pinned
  where singular; every grid) and "mgpcg" (CG preconditioned by a cell-centred multigrid
  V-cycle, fluid_multigrid; all-fluid grids of even cell counts >= 8).
Integrators: the schemes "sl_linear", "sl_cubic", "sl_cubic_clamped" with an optional
backtrace ":euler", ":rk2" (default) or ":rk3" (refsim.integrators.semi_lagrangian: names and
orders), and "steady" (one projection of the scene's initial field per step) where the scene's
meta asks solve = projection.
Refused with the reason: particles beside the grid (PIC/FLIP/APIC transfers: not written
here), 3D.
Observes "grid.u", "grid.v", "grid.p" (kinematic pressure of the last projection), the extras
"divergence", "residual", "iterations", as refsim's group.
"""
from __future__ import annotations

import time

import numpy as np

from refsim_adapters.common.grid_fluids import claims, integrator_reason, scene_reason
from refsim.engine import EngineFailure, ModelGroup, Sim
from refsim.integrators.semi_lagrangian import SCHEMES, parse_scheme, scheme_info
from refsim.scene import FluidGrid
from refsim.scene.fluid_grid import SOLID

FORMULATIONS = ("direct", "mgpcg")
STEADY = {"name": "steady", "order": 0, "family": "one pressure projection", "explicit": False,
          "symplectic": False}
INTEGRATORS = SCHEMES + ("steady",)
FEATURES = frozenset({"fluid_grid", "viscosity", "gravity", "free_surface", "solid_cells"})
WHO = "taichi grid fluids"


def supports(engine, scene, integrator):
    reason = scene_reason(scene, WHO, " (the particle-grid transfers, PIC/FLIP/APIC, are not "
                                      "written as taichi kernels)")
    if reason:
        return reason
    missing = sorted(scene.features() - FEATURES)
    if missing:
        return f"taichi does not simulate {', '.join(missing)}"
    return integrator_reason(scene, integrator, WHO)


def formulations(engine, scene):
    """direct always; mgpcg on all-fluid grids of even cell counts (fluid_multigrid)."""
    from ..fluid_solvers import multigrid_reason
    part = scene.part(FluidGrid)
    if part is None or multigrid_reason((part.nx, part.ny), part.marks):
        return FORMULATIONS[:1]
    return FORMULATIONS


def _solid_masks(marks, nx, ny):
    """(su, sv) int32: the faces of solid cells, held at 0."""
    su, sv = np.zeros((nx + 1, ny), np.int32), np.zeros((nx, ny + 1), np.int32)
    if marks is not None:
        solid = np.asarray(marks) == SOLID
        su[1:] |= solid
        su[:-1] |= solid
        sv[:, 1:] |= solid
        sv[:, :-1] |= solid
    return su, sv


class FluidState:
    """u, v, p of one grid and its step as kernels (module docstring)."""

    def __init__(self, part, scheme, gravity, dt, method="direct"):
        from .. import fluid_kernels as fk
        from .. import fluid_viscosity_kernels as vk
        from ..fluid_solvers import ImplicitViscosity, PressureSolver
        self.fk, self.vk, self.part, self.dt = fk, vk, part, float(dt)
        nx, ny, h = part.nx, part.ny, part.h
        self.periodic = tuple(s == "periodic" for s in part.sides)
        self.geo = fk.geometry(nx, ny, h, self.periodic, part.lid)
        self.interp, self.backtrace = parse_scheme(scheme)
        force = np.array(gravity[:2], float) if part.gravity else np.zeros(2)
        self.force = force
        self.u = np.array(part.u, np.float64, order="C")
        self.v = np.array(part.v, np.float64, order="C")
        self.p = np.zeros((nx, ny))
        self.pu = np.zeros(fk.padded_shape(self.u.shape, (1, 0), self.periodic))
        self.pv = np.zeros(fk.padded_shape(self.v.shape, (0, 1), self.periodic))
        self.un, self.vn = np.zeros_like(self.u), np.zeros_like(self.v)
        self.su, self.sv = _solid_masks(part.marks, nx, ny)
        self.pressure = PressureSolver(fk, self.geo, nx, ny, h, self.periodic, part.marks,
                                       method)
        self.viscous = None
        if part.nu > 0 and part.viscosity_scheme == "implicit":
            self.viscous = ImplicitViscosity(nx, ny, h, self.periodic, part.lid, dt, part.nu)
        self.info = {"iterations": 0, "residual": 0.0, "divergence": float(
            fk.max_divergence(self.u, self.v, self.pressure.fluid, self.geo))}

    def _pad(self, a, out, staggered, top):
        px, py = self.periodic
        self.fk.pad(a, out, staggered[0], staggered[1], int(px), int(py), 0, 0.0, 0.0, 0.0,
                    top)

    def advect(self):
        """(un, vn): u, v advected by themselves over dt (advection.advect_faces: ghost
        layers, departure points, interpolation, then the walls and periodic copies)."""
        fk, dt, geo = self.fk, self.dt, self.geo
        self._pad(self.u, self.pu, (1, 0), self.part.lid)
        self._pad(self.v, self.pv, (0, 1), 0.0)
        interp, stepper = fk.INTERP[self.interp], fk.BACKTRACE[self.backtrace]
        fk.advect(self.pu, self.pu, self.pv, self.un, geo, dt, 1, 0, interp, stepper)
        fk.advect(self.pv, self.pu, self.pv, self.vn, geo, dt, 0, 1, interp, stepper)
        fk.force_and_walls(self.un, self.vn, self.su, self.sv, geo, 0.0, 0.0, 0, 1, 0)
        return self.un, self.vn

    def step(self):
        """advect, force, viscosity, boundaries, project (FluidSolver.step)."""
        fk, dt, geo = self.fk, self.dt, self.geo
        u, v = self.advect()
        if self.force.any():
            fk.force_and_walls(u, v, self.su, self.sv, geo, dt * self.force[0],
                               dt * self.force[1], 1, 0, 0)
        if self.part.nu > 0.0:
            if self.viscous is not None:
                self.viscous.step(u, v)
            else:
                c = dt * self.part.nu
                self.vk.viscous_step(u, self.u, 0, geo, c, self.part.lid)
                self.vk.viscous_step(v, self.v, 1, geo, c, 0.0)
                u, v = self.u, self.v
        fk.force_and_walls(u, v, self.su, self.sv, geo, 0.0, 0.0, 0, 1, 1)
        self._project(u, v)

    def _project(self, u, v):
        p, iterations, residual, divergence = self.pressure.project(u, v, self.dt,
                                                                    self.part.rtol)
        if u is not self.u:  # keep the state in self.u / self.v, the other pair as scratch
            self.u, self.un = u, self.u
            self.v, self.vn = v, self.v
        self.p = p
        self.info = {"iterations": iterations, "residual": residual, "divergence": divergence}

    def project_initial(self):
        """One projection of the part's initial field."""
        self.un[...] = self.part.u
        self.vn[...] = self.part.v
        self._project(self.un, self.vn)


class FluidSim(Sim):
    """A FluidState stepped by dt (or, for "steady", one projection of the initial field per
    step)."""

    failures = (EngineFailure,)

    def __init__(self, scene, dt, integrator, formulation):
        from ..runtime import THREADS, effective_config, runtime
        rt = runtime()
        self.dt, self.part, self.steps = float(dt), scene.part(FluidGrid), 0
        self.method = formulation
        self.steady = integrator == "steady"
        self.scheme = "sl_linear" if self.steady else integrator
        self.threads, self.config = THREADS, effective_config()
        keys = [("grid_fluids",)] + ([("grid_fluids", "mgpcg")] if formulation == "mgpcg"
                                     else [])
        self.cold = any(key not in rt["compiled"] for key in keys)
        t0 = time.perf_counter()
        if ("grid_fluids",) not in rt["compiled"]:
            self._warm_up()
        if formulation == "mgpcg" and ("grid_fluids", "mgpcg") not in rt["compiled"]:
            self._warm_up_multigrid()
        rt["compiled"].update(keys)
        self.compile_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        self.state = FluidState(self.part, self.scheme, scene.gravity, self.dt, formulation)
        self.setup_s = time.perf_counter() - t0

    def _warm_up_multigrid(self):
        """Compile the multigrid kernels: one projection on an 8 x 8 grid (two levels)."""
        n = 8
        u = np.outer(np.arange(n + 1.0), np.arange(n) % 2)
        u[-1] = u[0] = 0.0
        tiny = FluidGrid(n, n, 0.125, u, np.zeros((n, n + 1)), sides=self.part.sides)
        FluidState(tiny, "sl_linear", (0.0, 0.0), 1.0, "mgpcg").project_initial()

    def _warm_up(self):
        """Compile every kernel: two steps of a 4 x 4 grid with the part's sides, explicit and
        implicit viscosity, a lid where walls allow (taichi compiles per array rank and dtype,
        not per shape or value: the real grid reuses them)."""
        walls_y = self.part.sides[1] == "wall"
        for scheme in ("explicit", "implicit"):
            n = 4
            u = np.outer(np.arange(n + 1.0), np.arange(n) % 2)  # some divergence
            v = np.outer(np.arange(n) % 3, np.arange(n + 1.0))
            u[-1] = u[0] = 0.0
            v[:, -1] = v[:, 0] = 0.0
            tiny = FluidGrid(n, n, 0.25, u, v, sides=self.part.sides, nu=0.01,
                             lid=1.0 if walls_y else 0.0, viscosity_scheme=scheme)
            state = FluidState(tiny, "sl_cubic:rk3", (0.0, -1.0), 0.01)
            state.step()
            state.project_initial()

    def _check(self):
        info = self.state.info
        if not info["residual"] <= self.part.rtol:
            raise EngineFailure(f"{WHO}: projection ({self.method}) stopped at relative residual "
                                f"{info['residual']:.3g} > rtol {self.part.rtol:g}")

    def _step_impl(self, n):
        for _ in range(n):
            if self.steady:
                self.state.project_initial()
            else:
                self.state.step()
            self._check()

    def _observe(self):
        s = self.state
        return {"grid.u": s.u.copy(), "grid.v": s.v.copy(), "grid.p": s.p.copy(),
                "divergence": float(s.info["divergence"]),
                "residual": float(s.info["residual"]), "iterations": int(s.info["iterations"])}

    def settings(self):
        from ..fluid_solvers import SOLVER_TEXT, VISCOSITY_TEXT
        from refsim.models.grid_fluid.advection import describe as advection_text
        part, s = self.part, self.state
        integrator = dict(STEADY) if self.steady else scheme_info(self.scheme)
        out = {"integrator": integrator, "dtype": "float64", "f64": True,
               "threads": self.threads, **self.config,
               "projection": {"formulation": self.method, "solver_text": SOLVER_TEXT[
                   self.method], **({"multigrid": s.pressure.mg.describe()} if
                                    s.pressure.mg is not None else {}),
                              "rtol": part.rtol, "unknowns": s.pressure.size,
                              "criterion": "||b - A p||_2 <= rtol ||b||_2 on the true "
                                           "residual (A p by a kernel), refinement restarts",
                              "null_space": "first fluid cell pinned, mean removed"
                              if s.pressure.singular else "none (air cells give p = 0)"},
               "cells": [part.nx, part.ny], "h": part.h, "sides": list(part.sides),
               "setup_s": self.setup_s,
               "arrays": "numpy float64 arrays handed to the kernels as external arrays "
                         "(arch=cpu: zero-copy); int32 masks",
               "compile": "cold JIT in this build (a 4 x 4 warm-up grid)" if self.cold else
               "kernels already compiled in this process"}
        if not self.steady:
            out.update(step="advect (semi-Lagrangian), body force, viscosity, project "
                            "(operator splitting, first order in dt): one Python iteration "
                            "per step, kernels and solves",
                       advection=advection_text(s.interp, s.backtrace),
                       viscosity={"nu": part.nu, "scheme": part.viscosity_scheme,
                                  "text": VISCOSITY_TEXT if part.viscosity_scheme ==
                                  "implicit" else "forward Euler, one kernel sweep per "
                                                  "component"},
                       lid=part.lid, body_force=s.force.tolist(), density=part.density)
        return out

    def close(self):
        self.state = None


def build(engine, scene, dt, integrator, formulation):
    return FluidSim(scene, dt, integrator, formulation or FORMULATIONS[0])


MODEL_GROUP = ModelGroup(name="grid_fluids", build=build, claims=claims,
                         parts=None, features=None,  # supports names other parts first
                         supports=supports, formulations=formulations, integrators=INTEGRATORS)
