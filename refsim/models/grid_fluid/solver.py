"""One time step of the MAC-grid Navier-Stokes solver, and the schemes' names.

Step (operator splitting, Chorin's projection method as in Stam 1999 / Bridson 2015):
1. advect u, v semi-Lagrangian (refsim.models.grid_fluid.advection) through u^n;
2. add the body force (the scene's gravity, x and y components, where the part asks);
3. viscosity nu lap u (refsim.models.grid_fluid.viscosity), explicit or implicit;
4. walls and solid faces set to 0, periodic duplicates copied; project
   (refsim.models.grid_fluid.projection): D u^{n+1} = 0 to the solver's tolerance.

Scheme names (the engines' integrators, refsim.integrators.semi_lagrangian: parse_scheme,
scheme_info): "sl_<interpolant>[:<backtrace>]", interpolant one of linear, cubic,
cubic_clamped and backtrace one of euler, rk2 (the default), rk3, e.g. "sl_linear:rk2".
Orders: the splitting is first order in dt (order 1, every scheme: the advection, viscous and
pressure substeps do not commute); the backtrace is of order 1, 2 or 3
in dt along the characteristic; the interpolation errs by O(h^2) (linear) or O(h^3) (cubic)
per step, O(h^(p+1) / dt) over a unit time; the viscous and pressure operators are second
order in h. On the Taylor-Green vortex (a steady solution of the Euler equations) both show
as numerical viscosity: the splitting's U^2 dt / 8 (advecting through the frozen u^n, then
projecting) and the bilinear interpolant's ~0.225 U h (cases/grid_fluids/taylor_green.py
derives and measures them).
"""
from __future__ import annotations

import numpy as np

from refsim.integrators.semi_lagrangian import (DEFAULT_BACKTRACE, SCHEMES, SPLITTING_ORDER,
                                                parse_scheme, scheme_info)
from refsim.scene.fluid_grid import SOLID

from . import advection
from .mac import MacGrid, divergence, enforce_boundaries
from .projection import PressureSystem
from .viscosity import Viscosity

__all__ = ["DEFAULT_BACKTRACE", "SCHEMES", "SPLITTING_ORDER", "FluidSolver", "parse_scheme",
           "scheme_info"]  # the scheme names re-exported beside the solver


class FluidSolver:
    """The state (u, v, p) of a `FluidGrid` part and its step. gravity: the scene's (x, y)
    body force per unit mass, applied when the part says so; method: the projection solver."""

    def __init__(self, part, scheme="sl_linear:rk2", method="direct", gravity=(0.0, 0.0)):
        self.part, self.grid = part, MacGrid.of(part)
        self.interpolant, self.backtrace = parse_scheme(scheme)
        self.method, self.rtol = method, part.rtol
        self.force = np.array(gravity[:2], float) if part.gravity else np.zeros(2)
        self.u, self.v = np.array(part.u, float), np.array(part.v, float)
        self.p = np.zeros(self.grid.cells)
        self.pressure = PressureSystem(self.grid, part.marks)
        self.viscosity = Viscosity(self.grid)
        self.solid_u, self.solid_v = self._solid_faces(part.marks)
        self.info = {"iterations": 0, "residual": 0.0,
                     "divergence": float(np.max(np.abs(divergence(self.u, self.v,
                                                                  self.grid.h))))}

    def _solid_faces(self, marks):
        if marks is None or not np.any(marks == SOLID):
            return None, None
        solid = marks == SOLID
        su = np.zeros((self.grid.nx + 1, self.grid.ny), bool)
        sv = np.zeros((self.grid.nx, self.grid.ny + 1), bool)
        su[1:] |= solid
        su[:-1] |= solid
        sv[:, 1:] |= solid
        sv[:, :-1] |= solid
        return su, sv

    def step(self, dt):
        """One step of dt: advect, force, viscosity, project (updates u, v, p, info)."""
        u, v = advection.advect_faces(self.u, self.v, self.grid, dt, self.interpolant,
                                      self.backtrace)
        if self.force.any():
            u = u + dt * self.force[0]
            v = v + dt * self.force[1]
        u, v = self.viscosity.step(u, v, dt, self.part.nu, self.part.viscosity_scheme)
        enforce_boundaries(u, v, self.grid)
        if self.solid_u is not None:
            u[self.solid_u], v[self.solid_v] = 0.0, 0.0
        self.u, self.v, self.p, self.info = self.pressure.project(u, v, dt, self.method,
                                                                  self.rtol)

    def project_only(self, dt=1.0):
        """One projection of the current field (no advection, force or viscosity)."""
        self.u, self.v, self.p, self.info = self.pressure.project(self.u, self.v, dt,
                                                                  self.method, self.rtol)

    def describe(self) -> dict:
        return {"scheme": f"sl_{self.interpolant}:{self.backtrace}",
                "step": "advect (semi-Lagrangian), body force, viscosity, project "
                        "(operator splitting, first order in dt)",
                "advection": advection.describe(self.interpolant, self.backtrace),
                "viscosity": {"nu": self.part.nu,
                              **Viscosity.describe(self.part.viscosity_scheme)},
                "projection": self.pressure.describe(self.method, self.rtol),
                "cells": list(self.grid.cells), "h": self.grid.h,
                "sides": list(self.part.sides), "lid": self.part.lid,
                "body_force": self.force.tolist(), "density": self.part.density}
