"""PhiFlow's grid-fluid group (issue 27): a peer, stepping one `FluidGrid` (2D MAC grid, all
fluid, walls with the lid or periodic axes) PhiFlow's own way, as a `phi.field.StaggeredGrid`
(refsim_adapters.phiflow_engine.staggered: the face layout and the boundary), in float64
(`phi.math.precision(64)`, the field's dtype checked at build) on phiml's numpy backend.

One step of dt (operator splitting, PhiFlow's functions in this order):
1. advection of the velocity by itself: "phi_semi_lagrangian" = `advect.semi_lagrangian(u, u,
   dt)` (backtrace x - dt u(x), PhiFlow's `advect.euler`, u sampled by PhiFlow's linear
   interpolation at the departure point) or "phi_mac_cormack" = `advect.mac_cormack(u, u, dt)`
   (a forward and a backward semi-Lagrangian lookup, the first-order error estimate added at
   correction strength 1, clamped to the neighbours of the backward lookup);
2. viscosity nu (when nu > 0): `diffuse.implicit(u, nu, dt, solve=Solve('CG', ...))` where the
   part asks "implicit" and PhiFlow can (periodic axes: it fails on a staggered grid with walls
   in phiflow 3.4.0, ValueError "Shape (x=nx-1, y=ny) has no dimension 'idx'", so the build
   tries it and falls back, saying so in the settings), else `diffuse.explicit(u, nu, dt,
   substeps=k)` with k = max(1, ceil(4 nu dt / h^2)) substeps so that each one is stable
   (nu dt / (k h^2) <= 1/4 in 2D; k = 1 where the part itself asks "explicit");
3. `fluid.make_incompressible(u, solve=Solve('CG', rel_tol=part.rtol, abs_tol=0,
   max_iterations=2 nx ny))`: PhiFlow's CG stops on its recursive residual, ||r||_2 <=
   rel_tol ||div u*||_2; its pressure p_phi is dt times the kinematic pressure (u - grad p_phi).
PhiFlow's integrators are its own names, which refsim's method_info does not know: the rows
have no method bound (consistency "no method reference") and only the case's target judges
them, as it should for a peer.

Boundary differences from refsim's model (why the numbers differ, docs/engine_notes.md#phiflow):
a constant extrapolation pads the tangential velocity with the wall's value itself (ghost =
U_wall, measured: one explicit diffusion step from rest gives the top row nu dt / h^2 U, half
of refsim's 2 nu dt / h^2 U with the MAC ghost 2 U - u), so PhiFlow's no-slip and lid act h/2
outside the wall: a first-order boundary error.

Observes "grid.u" (nx + 1, ny), "grid.v" (nx, ny + 1) (refsim's layout, staggered.pad),
"grid.p" (nx, ny) = p_phi / dt with its mean removed (m^2/s^2), and the extras "divergence"
(max |D u| over the cells by refsim's operator, 1/s), "residual" (||D u||_2 / ||D u*||_2 of the
last projection: the true relative residual of D G p = D u* when PhiFlow's Poisson matrix is
D G, as for walls and periodic axes) and "iterations" (its CG's, from a phiml SolveTape).
Refused with the reason: anything beside the grid, 3D, cell marks (free surface, solid cells),
a body force, the one-projection scenes (meta solve = projection), and "phi_mac_cormack" with a
moving lid (PhiFlow 3.4.0's MacCormack fails on the lid's vector extrapolation: AssertionError
"Cannot pad tensor ... non-batch dimension 'vector' is missing"; it runs on still walls and
periodic axes).
"""
from __future__ import annotations

import math
import re
import warnings

import numpy as np

from refsim.engine import EngineFailure, ModelGroup, Sim
from refsim.integrators.spec import IntegratorSpec
from refsim.scene import FluidGrid

from .. import staggered

WHO = "PhiFlow peer"
INTEGRATORS = ("phi_semi_lagrangian", "phi_mac_cormack")
ADVECTION = {
    "phi_semi_lagrangian": ("advect.semi_lagrangian(u, u, dt): backtrace by advect.euler "
                            "(x - dt u(x)), u sampled by linear interpolation"),
    "phi_mac_cormack": ("advect.mac_cormack(u, u, dt, correction_strength=1): forward and "
                        "backward semi-Lagrangian lookups (advect.euler), the error estimate "
                        "added, clamped to the backward lookup's neighbours"),
}
# phiml warns on every singular matrix solve: the walls' or periodic axes' pressure matrix is
# singular by one (constants), which make_incompressible declares (rank_deficiency=1) and phiml
# solves by bordering it with a row and column of ones; the settings say so
RANK_WARNING = "Rank deficiency"
EXPLICIT_LIMIT = 0.25  # nu dt / h^2 of one explicit 2D diffusion substep: stable up to 1/4


def claims(scene) -> bool:
    return scene.part(FluidGrid) is not None


def supports(engine, scene, integrator):
    if scene.part_kinds() != {"fluid_grids"}:
        others = ", ".join(sorted(scene.part_kinds() - {"fluid_grids"}))
        return f"{WHO}: a fluid grid alone (the cavity and Taylor-Green), got also {others}"
    if scene.dim != 2:
        return f"{WHO}: 2D grids only here, got dim {scene.dim}"
    part = scene.part(FluidGrid)
    if part.marks is not None:
        return (f"{WHO}: all-fluid grids only (free surface and solid cells are not mapped "
                "onto PhiFlow's obstacles here)")
    if part.gravity and any(scene.gravity[:2]):
        return f"{WHO}: no body force here (the cavity and Taylor-Green have none)"
    if scene.meta.get("solve") == "projection":
        return (f"{WHO}: time stepping only (the cavity and Taylor-Green); the one-projection "
                "scene is not offered")
    if integrator is not None:
        spec = IntegratorSpec.parse(integrator)
        if spec.name not in INTEGRATORS or spec.colon:
            return f"{WHO}: integrator one of {list(INTEGRATORS)}, got {integrator!r}"
        if spec.name == "phi_mac_cormack" and part.lid:
            return (f"{WHO}: PhiFlow 3.4.0's advect.mac_cormack fails on a moving wall's "
                    "vector extrapolation (AssertionError: Cannot pad tensor ... because "
                    "non-batch dimension 'vector' is missing); phi_semi_lagrangian runs it")
    return None


def _cg(rtol, cells):
    from phi.math import Solve
    return Solve("CG", rel_tol=rtol, abs_tol=0.0, max_iterations=2 * cells)


class PhiFluidSim(Sim):
    """A StaggeredGrid stepped by PhiFlow's advect, diffuse and make_incompressible."""

    def __init__(self, scene, dt, integrator):
        from phi import math as pm
        from phi.physics import advect, diffuse, fluid
        self.pm, self.diffuse, self.fluid = pm, diffuse, fluid
        self.advect = advect.semi_lagrangian if integrator == INTEGRATORS[0] \
            else advect.mac_cormack
        self.failures = (EngineFailure, pm.ConvergenceException)
        self.dt, self.integrator = float(dt), integrator
        self.part = part = scene.part(FluidGrid)
        self.periodic = tuple(s == "periodic" for s in part.sides)
        self.solve = _cg(part.rtol, part.nx * part.ny)
        with pm.precision(64):
            self.ext = staggered.boundary(part)
            self.grid = staggered.to_grid(part.u, part.v, part, self.ext)
            dtype = self.grid.values.dtype
            if (dtype.kind, dtype.bits) != (float, 64):
                raise EngineFailure(f"{WHO}: the field is {dtype}, not float64")
            self.viscosity, self.substeps, self.fallback = self._viscosity()
        self.u, self.v = (np.array(part.u, float), np.array(part.v, float))
        self.p = np.zeros(part.shape)
        self.info = {"divergence": float(np.abs(staggered.divergence(
            self.u, self.v, part.h)).max()), "residual": 0.0, "iterations": 0}

    def _viscosity(self):
        """("none" | "implicit" | "explicit", substeps, why implicit fell back or "")."""
        part = self.part
        if part.nu == 0:
            return "none", 0, ""
        if part.viscosity_scheme == "implicit":
            try:
                self.diffuse.implicit(self.grid, part.nu, self.dt, solve=self.solve)
                return "implicit", 1, ""
            except Exception as exc:  # PhiFlow's own failure: recorded in the settings
                why = f"{type(exc).__name__}: {str(exc).splitlines()[0][:120]}"
                k = max(1, math.ceil(part.nu * self.dt / part.h ** 2 / EXPLICIT_LIMIT))
                return "explicit", k, why
        return "explicit", 1, ""

    def _step_one(self):
        g = self.advect(self.grid, self.grid, self.dt)
        if self.viscosity == "implicit":
            g = self.diffuse.implicit(g, self.part.nu, self.dt, solve=self.solve)
        elif self.viscosity == "explicit":
            g = self.diffuse.explicit(g, self.part.nu, self.dt, substeps=self.substeps)
        before = np.linalg.norm(staggered.divergence(*staggered.from_grid(g, self.part),
                                                     self.part.h))
        with self.pm.SolveTape() as tape, warnings.catch_warnings():
            warnings.filterwarnings("ignore", RANK_WARNING, RuntimeWarning)
            g, p = self.fluid.make_incompressible(g, solve=self.solve)
        self.grid = g
        self.u, self.v = staggered.from_grid(g, self.part)
        div = staggered.divergence(self.u, self.v, self.part.h)
        pressure = p.values.numpy("x,y") / self.dt
        self.p = pressure - pressure.mean()
        self.info = {"divergence": float(np.abs(div).max()),
                     "residual": float(np.linalg.norm(div) / before) if before > 0 else 0.0,
                     "iterations": int(tape[0].iterations.max) if len(tape.solves) else 0}

    def _step_impl(self, n):
        with self.pm.precision(64):
            for _ in range(n):
                self._step_one()
        if not (np.isfinite(self.u).all() and np.isfinite(self.v).all()):
            raise EngineFailure(f"{WHO}: non-finite velocity")

    def _observe(self):
        return {"grid.u": self.u.copy(), "grid.v": self.v.copy(), "grid.p": self.p.copy(),
                **self.info}

    def settings(self):
        import phi
        from phiml.backend import default_backend
        part = self.part
        nu_dt = part.nu * self.dt / part.h ** 2
        viscosity = {
            "none": "none (nu = 0)",
            "implicit": (f"diffuse.implicit(u, nu, dt, solve=CG at rel_tol {part.rtol:g}) "
                         "(backward Euler, as the part asks)"),
            "explicit": (f"diffuse.explicit(u, nu, dt, substeps={self.substeps}) (forward "
                         f"Euler, nu dt / h^2 = {nu_dt:.3g} per step)"
                         + (f"; the part asks implicit, and PhiFlow's diffuse.implicit failed "
                            f"here: {self.fallback}" if self.fallback else "")),
        }[self.viscosity]
        return {
            "integrator": {"name": self.integrator, "order": 1.0, "symplectic": False,
                           "implicit": False, "family": "PhiFlow's own semi-Lagrangian "
                           "projection (operator splitting: first order in dt)"},
            "advection": ADVECTION[self.integrator],
            "viscosity": viscosity,
            "projection": (f"fluid.make_incompressible(u, solve=Solve('CG', rel_tol="
                           f"{part.rtol:g}, abs_tol=0, max_iterations={2 * part.nx * part.ny}"
                           ")): PhiFlow's CG stops on its recursive residual ||r||_2 <= "
                           "rel_tol ||div u*||_2; the singular pressure matrix (constants) "
                           "bordered by a row and column of ones (phiml, rank_deficiency=1; its "
                           "RuntimeWarning silenced); p = p_phi / dt, mean removed"),
            "boundary": re.sub(r"\x1b\[[0-9;]*m", "", str(self.ext)),
            "precision": "float64 (phi.math.precision(64); the field's dtype checked)",
            "dtype": "float64", "backend": default_backend().name, "threads": 1,
            "phiflow": phi.__version__, "phiml": _version("phiml"),
            "cells": [part.nx, part.ny], "h": part.h, "sides": list(part.sides),
            "nu": part.nu, "lid": part.lid,
        }


def _version(dist):
    from refsim.engine import installed_version
    return installed_version(dist)


def build(engine, scene, dt, integrator, formulation):
    return PhiFluidSim(scene, dt, integrator or INTEGRATORS[0])


MODEL_GROUP = ModelGroup(name="grid_fluids", build=build, claims=claims,
                         parts=None, features=None,  # supports gives the reasons
                         supports=supports, integrators=INTEGRATORS)
