"""The in-house engine's finite-difference group (slides 000/001): the heat equation
u_t = D lap u and the wave equation u_tt = c^2 lap u on one `Grid` part (1D, 2D or 3D;
Dirichlet, Neumann or periodic sides), by the method of lines (refsim.models.grid_pde).

Heat: FTCS (explicit_euler), midpoint, heun, rk4 (the first-order tableaux of
refsim.integrators.first_order on the whole field), implicit_euler and crank_nicolson (one
SuperLU factorisation per run, refsim.integrators.sparse_linear). Wave: stormer_verlet (the
three-level leapfrog), velocity_verlet, symplectic_euler, rk4 (refsim.integrators on the field
as a second-order system), implicit_euler and implicit_midpoint (sparse LU).

Observes grid.<name> for each of the grid's fields: the heat equation's one field, the wave
equation's u (m) and v (m/s), each of the grid's shape.
"""
from __future__ import annotations

import numpy as np

from refsim_adapters.common.grid_pde import (
    FIRST_ORDER_SPARSE,
    SECOND_ORDER_IMPLICIT,
    evolution_group,
    field_name,
    fields_of,
    integrator_reason,
    scene_reason,
)
from refsim.engine import Sim
from refsim.integrators import get_integrator
from refsim.integrators.first_order import get_first_order
from refsim.integrators.sparse_linear import first_order_implicit, second_order_implicit
from refsim.models.grid_pde import GridPDE
from refsim.scene import Grid

from ..stepped import SteppedSim


def supports(engine, scene, integrator):
    return scene_reason(scene, "refsim") or integrator_reason(scene.part(Grid), integrator)


class HeatSim(Sim):
    """u' = D lap u advanced by a first-order stepper on the whole field."""

    def __init__(self, grid, dt, integrator):
        self.dt, self.grid = float(dt), grid
        self.system = GridPDE(grid)
        self.stepper = first_order_implicit(integrator) if integrator in FIRST_ORDER_SPARSE \
            else get_first_order(integrator)
        self.name = field_name(grid)
        self.u, _ = fields_of(grid)
        self.stepper_t = 0.0

    def _step_impl(self, n):
        with np.errstate(all="ignore"):
            self.stepper_t, self.u = self.stepper.advance(self.system, self.stepper_t, self.u,
                                                          self.dt, n)

    def _observe(self):
        return {f"grid.{self.name}": self.u.copy()}

    def settings(self):
        return {"integrator": self.stepper.describe(), "dtype": "float64", "threads": 1,
                "model": self.system.describe(), "points": int(self.u.size),
                "solve": ("scipy.sparse.linalg.splu of (I - theta h A), factorised once per "
                          "run" if not self.stepper.explicit else "none (explicit)"),
                "vectorised": "numpy slices over the whole field, one per stencil side"}


class WaveSim(SteppedSim):
    """u'' = c^2 lap u advanced by a second-order stepper on (u, v)."""

    def __init__(self, grid, dt, integrator):
        stepper = second_order_implicit(integrator) if integrator in SECOND_ORDER_IMPLICIT \
            else get_integrator(integrator)
        u, v = fields_of(grid)
        super().__init__(dt, stepper, GridPDE(grid), u, v)

    def stages(self):
        return ["wave: c^2 lap u (slices)", f"integrate:{self.stepper.name}"]

    def _observe(self):
        u, v = self.coordinates()
        return {"grid.u": np.array(u, float), "grid.v": np.array(v, float)}

    def settings(self):
        return {**self.base_settings(), "model": self.system.describe(),
                "points": int(np.size(self.state[0])),
                "solve": ("scipy.sparse.linalg.splu, factorised once per run"
                          if not self.stepper.explicit else "none (explicit)")}


MODEL_GROUP = evolution_group(HeatSim, WaveSim, supports)
