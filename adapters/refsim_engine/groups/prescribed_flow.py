"""The in-house engine's prescribed-flow advection (issue 27, case 4: LeVeque's single vortex,
Zalesak's rotation): a `PrescribedFlow` part moves either
- `Particles` (massless markers, p' = u(t, p)), stepped by the first-order steppers of
  refsim.integrators.first_order ("explicit_euler", "midpoint", "heun", "rk2" (Ralston),
  "rk4"; "implicit_euler" on the affine rotation only); observes x (n, 3), v = u(t, x);
- or a level set: one `Grid` of model "level_set" with the cell field "phi" (points at the
  MAC cell centres: origin = spacing / 2, square cells), advected by the group's semi-Lagrangian
  interpolants and backtrace tableaux (refsim.models.grid_fluid.level_set) through the
  analytic velocity; integrators "sl_<linear|cubic|cubic_clamped>:<euler|rk2|rk3>" (the
  names of refsim.integrators.semi_lagrangian); observes "grid.phi".
Formulations of a level set: "" (no reinitialisation) and "reinit_every_16" (phi redistanced
to its interpolant's zero line after every 16th step, within 6 cells of it: level_set.
redistance); particles: "".
The module name sorts after "particles" and "grid_*", whose claims leave these scenes alone
(a Grid of model "level_set" is neither diffusion, wave nor poisson; particles beside a
prescribed_flow part are not the particles group's kinds).
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup, Sim
from refsim.integrators.first_order import get_first_order
from refsim.integrators.semi_lagrangian import BACKTRACES, INTERPOLANTS, parse_scheme, \
    scheme_info
from refsim.models.grid_fluid.level_set import LevelSetAdvection
from refsim.models.grid_fluid.mac import MacGrid
from refsim.models.grid_fluid.prescribed_flow import Flow
from refsim.scene import Grid, Particles
from refsim.scene.prescribed_flow import PrescribedFlow

LEVEL_SET = tuple(f"sl_{i}:{b}" for i in INTERPOLANTS for b in BACKTRACES)
PARTICLE = ("explicit_euler", "midpoint", "heun", "rk2", "rk4", "implicit_euler")
# the bare scheme names let the engine's spec check (spec_name) pass the combinations; the
# level set refuses them (its backtrace is named): no duplicate rows of the default rk2
INTEGRATORS = LEVEL_SET + PARTICLE + ("sl_linear", "sl_cubic", "sl_cubic_clamped")


REINIT = "reinit_every_16"


def formulations(engine, scene):
    return ("", REINIT) if scene.part(Grid) is not None else ("",)


def reinit_every(formulation) -> int:
    """Steps between redistancings of a formulation name ("reinit_every_<k>"; "" never)."""
    return int(formulation.rsplit("_", 1)[1]) if formulation else 0


def claims(scene) -> bool:
    return scene.part(PrescribedFlow) is not None


def _level_set_reason(scene) -> str | None:
    grids = scene.parts_of(Grid)
    if len(grids) != 1 or grids[0].model != "level_set" or set(grids[0].fields) != {"phi"}:
        return ("refsim prescribed flow: one Grid of model 'level_set' with the one field "
                "'phi'")
    g = grids[0]
    if len(g.shape) != 2 or g.spacing[0] != g.spacing[1] or \
            any(o != 0.5 * s for o, s in zip(g.origin, g.spacing)):
        return ("refsim prescribed flow: the level set's grid is 2D with square cells, its "
                "points at the cell centres (origin = spacing / 2)")
    return None


def supports(engine, scene, integrator):
    kinds = scene.part_kinds()
    if kinds == {"prescribed_flow", "particles"}:
        if integrator is None:
            return None
        if integrator not in PARTICLE:
            return (f"refsim prescribed flow: particles p' = u(t, p) step with the first-order "
                    f"steppers {list(PARTICLE)}, got {integrator!r}")
        if integrator == "implicit_euler" and not scene.part(PrescribedFlow).affine:
            return ("refsim prescribed flow: implicit_euler solves affine fields only (one "
                    "linear solve a step); the single vortex is not affine in p")
        return None
    if kinds == {"prescribed_flow", "grids"}:
        reason = _level_set_reason(scene)
        if reason is not None or integrator is None:
            return reason
        if integrator not in LEVEL_SET:
            return (f"refsim prescribed flow: a level set steps with the semi-Lagrangian "
                    f"schemes {list(LEVEL_SET)}, got {integrator!r}")
        return None
    return ("refsim prescribed flow: particles or one level-set grid beside the flow, got "
            f"{', '.join(sorted(kinds))}")


class ParticleFlowSim(Sim):
    """Markers p' = u(t, p) (all at once) by a first-order stepper."""

    def __init__(self, scene, dt, integrator):
        self.dt, self.integrator = float(dt), integrator
        self.stepper = get_first_order(integrator)
        self.flow = Flow(scene.part(PrescribedFlow))
        self.p = np.array(scene.part(Particles).position, float)
        self.k = 0

    def _step_impl(self, n):
        for _ in range(n):  # the step's start time from the count (no running sum)
            self.p = self.stepper.step(self.flow, self.k * self.dt, self.p, self.dt)
            self.k += 1

    def _observe(self):
        return {"x": self.p.copy(), "v": self.flow.velocity(self.k * self.dt, self.p)}

    def settings(self):
        return {"integrator": self.stepper.describe(), "dtype": "float64", "threads": 1,
                "system": "first order p' = u(t, p) (masses and initial velocities ignored)",
                "model": self.flow.describe(), "observed_v": "u(t, p) at the observed p",
                "vectorised": "numpy over particles"}


class LevelSetSim(Sim):
    """phi on the cells advected by the analytic flow (semi-Lagrangian)."""

    def __init__(self, scene, dt, integrator, formulation=""):
        self.dt, self.reinit = float(dt), reinit_every(formulation)
        grid = scene.part(Grid)
        self.integrator = integrator
        self.flow = Flow(scene.part(PrescribedFlow))
        self.mac = MacGrid(grid.shape[0], grid.shape[1], grid.spacing[0])
        interpolant, backtrace = parse_scheme(integrator)
        self.model = LevelSetAdvection(grid.fields["phi"], self.mac, self.flow.velocity_2d,
                                       interpolant, backtrace, self.reinit)

    def _step_impl(self, n):
        self.model.step(self.dt, n)

    def _observe(self):
        return {"grid.phi": self.model.phi.copy()}

    def settings(self):
        interpolant, backtrace = parse_scheme(self.integrator)
        return {"integrator": scheme_info(self.integrator), "dtype": "float64", "threads": 1,
                "model": self.flow.describe(), "cells": [self.mac.nx, self.mac.ny],
                "h": self.mac.h, "interpolant": interpolant, "backtrace": backtrace,
                "velocity": "analytic u(t, x) at each backtrace stage (stage k at t^(n+1) - "
                            "c_k dt), no grid sampling",
                "walls": "even ghosts (zero normal gradient), departure points clamped into "
                         "the domain",
                "order_note": "pure advection: no splitting; the declared order 1 is the "
                              "scheme name's (refsim.integrators.semi_lagrangian)",
                "reinitialisation": (f"redistanced after every {self.reinit}th step to the zero "
                                     "line of phi's piecewise-linear interpolant, within 6 "
                                     "cells of it (clamped beyond)") if self.reinit else "none",
                "vectorised": "numpy over all cells"}


def build(engine, scene, dt, integrator, formulation):
    if scene.part(Particles) is not None:
        return ParticleFlowSim(scene, dt, integrator)
    return LevelSetSim(scene, dt, integrator, formulation or "")


MODEL_GROUP = ModelGroup(name="prescribed_flow", build=build, claims=claims,
                         parts=frozenset({"prescribed_flow", "particles", "grids"}),
                         features=frozenset({"prescribed_flow", "leveque_vortex",
                                             "zalesak_rotation", "grid", "level_set"}),
                         supports=supports, formulations=formulations,
                         integrators=INTEGRATORS)
