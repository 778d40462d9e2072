"""What the engines' finite-difference groups share (refsim and taichi run the same schemes on
the same `Grid` parts): which scenes they claim, the steppers offered per PDE, and the reasons
a stepper or a scene is refused."""
from __future__ import annotations

import numpy as np

from refsim.integrators import INTEGRATORS
from refsim.integrators.spec import spec_name
from refsim.models.grid_pde import MODELS, coefficient_reason
from refsim.scene import Grid

# heat equation u' = D lap u (first order): FTCS is explicit Euler; RK tableaux on the method
# of lines; the theta-methods by a sparse solve
DIFFUSION_INTEGRATORS = ("explicit_euler", "midpoint", "heun", "rk4", "implicit_euler",
                         "crank_nicolson")
# wave equation u'' = c^2 lap u (second order): Stormer-Verlet is the three-level leapfrog
# u^{n+1} = 2 u^n - u^{n-1} + h^2 c^2 lap u^n; velocity Verlet gives the same u sequence
WAVE_INTEGRATORS = ("stormer_verlet", "velocity_verlet", "symplectic_euler", "rk4",
                    "implicit_euler", "implicit_midpoint")
OFFERED = tuple(dict.fromkeys(DIFFUSION_INTEGRATORS + WAVE_INTEGRATORS))
FIRST_ORDER_IMPLICIT = ("implicit_euler", "crank_nicolson")
FIRST_ORDER_SPARSE = ("explicit_euler",) + FIRST_ORDER_IMPLICIT  # sparse_linear.ThetaMethod
SECOND_ORDER_IMPLICIT = ("implicit_euler", "implicit_midpoint")


def claims(scene) -> bool:
    """One grid carrying the heat or the wave equation, and nothing else that moves."""
    return bool(scene.parts_of(Grid)) and any(g.model in MODELS for g in scene.parts_of(Grid))


def scene_reason(scene, who: str) -> str | None:
    """Reasons a grid scene is refused whatever the stepper."""
    if len(scene.parts_of(Grid)) != 1:
        return f"{who} finite differences: one grid per scene, got {len(scene.parts_of(Grid))}"
    if scene.part_kinds() != {"grids"}:
        others = sorted(scene.part_kinds() - {"grids"})
        return f"{who} finite differences: a grid alone, got also {', '.join(others)}"
    grid = scene.part(Grid)
    reason = coefficient_reason(grid)
    if reason:
        return f"{who} finite differences: {reason}"
    if grid.model == "diffusion" and len(grid.fields) != 1:
        return f"{who} heat equation: one field (u), got {sorted(grid.fields)}"
    if grid.model == "wave" and ("u" not in grid.fields or set(grid.fields) - {"u", "v"}):
        return f"{who} wave equation: fields u and optionally v, got {sorted(grid.fields)}"
    return None


def offered_for(grid) -> tuple:
    return DIFFUSION_INTEGRATORS if grid.model == "diffusion" else WAVE_INTEGRATORS


def integrator_reason(grid, integrator: str | None) -> str | None:
    if integrator is None:
        return None
    name = spec_name(integrator)
    offered = offered_for(grid)
    if name in offered and name == integrator:
        return None
    if grid.model == "diffusion" and name in INTEGRATORS:
        return (f"heat equation u' = D lap u is first order: {integrator!r} steps second-order "
                f"systems; offered here: {list(offered)}")
    if grid.model == "wave" and name == "crank_nicolson":
        return ("wave equation: Crank-Nicolson is offered as implicit_midpoint (the "
                "trapezoidal rule on (u, v)); offered here: " + str(list(offered)))
    return f"{grid.model} grids: integrator must be one of {list(offered)}, got {integrator!r}"


def fields_of(grid):
    """(u, v) initial arrays (v None for diffusion; zeros when a wave grid has no v)."""
    u = np.array(grid.fields["u"] if "u" in grid.fields else next(iter(grid.fields.values())),
                 float)
    if grid.model != "wave":
        return u, None
    v = np.array(grid.fields["v"], float) if "v" in grid.fields else np.zeros_like(u)
    return u, v


def field_name(grid) -> str:
    return "u" if "u" in grid.fields else next(iter(grid.fields))


def grid_refusal_sentence(engine: str, what: str) -> str:
    """The `refusals["grids"]` sentence of an engine without a grid/PDE solver."""
    return (f"{engine} has no finite-difference grid solver ({what}); the heat, wave and "
            "Poisson grids run on refsim and taichi")


def evolution_group(heat_sim, wave_sim, supports):
    """The heat-and-wave MODEL_GROUP of an engine: `heat_sim(grid, dt, integrator)` for
    diffusion grids, `wave_sim(...)` for wave grids (refsim and taichi declare the same)."""
    from refsim.engine import ModelGroup

    def build(engine, scene, dt, integrator, formulation):
        grid = scene.part(Grid)
        return (heat_sim if grid.model == "diffusion" else wave_sim)(grid, dt, integrator)
    return ModelGroup(name="grid_evolution", build=build, claims=claims,
                      parts=frozenset({"grids"}), features=frozenset({"grid", "diffusion",
                                                                      "wave"}),
                      supports=supports, integrators=OFFERED)
