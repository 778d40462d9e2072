"""The in-house engine's finite-element group (slides 001 and 000): one P1 mesh part
(`TriangleMesh`, plane stress or plane strain, or `TetMesh`) of one material and strain
measure (refsim.models.fem_*), pinned nodes held at the mesh's `positions`, constant nodal
loads and gravity.

Two ways to run it, chosen by the scene: `scene.meta["solve"] == "static"` (the case compares
the equilibrium) offers only
- "steady": no time stepping; one `step()` is one complete static Newton solve
  (refsim.models.fem.static: SuperLU on the free dofs, stopping at NEWTON_RTOL of the force
  scale or at the positions' round-off) from the mesh's initial positions, so a timing pass of
  fresh Sims times the whole solve (assembly pattern included). The equilibrium is what is
  observed after the first step; before it, the initial positions.
and any other scene only
- a `refsim.integrators` stepper on `FemSystem` (lumped masses, free nodes' world positions):
  the explicit steppers, implicit Euler and Baraff-Witkin (sparse from SPARSE_MIN dofs).
  A plastic material commits its plastic strain after every accepted step.

Formulations: "" the correct nodal forces; "as_printed" slide 001's printed nodal force
f_i = Q sigma n_i (unit normals, no face weight: refsim.models.fem.printed says what it does),
run beside it so that the harness shows the slip, in both ways of running.

Observes x, v (n, 3) of every node (pinned ones included), and for "steady" `residual` (max
|f_int + f_ext| on the free dofs at the end, N) and `iterations` (Newton iterations of the last
solve; 0 before any).
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup, Sim
from refsim.integrators import get_integrator
from refsim.integrators.spec import spec_name
from refsim.models.fem import printed as fem_printed
from refsim.models.fem.static import solve_static
from refsim.models.fem.system import FemSystem
from refsim.scene import single_mesh

from ..stepped import SteppedSim

STEPPERS = ("explicit_euler", "symplectic_euler", "velocity_verlet", "rk4", "implicit_euler",
            "baraff_witkin")
INTEGRATORS = ("steady",) + STEPPERS
STEADY = {"name": "steady", "order": 0, "family": "static solve (Newton)", "explicit": False,
          "symplectic": False}
NEWTON_RTOL = 1e-12  # of the force scale: a residual this small moves nodes by ~1e-12 of the
#                      load's displacement, below every FEM case's tolerance


def _mesh(scene):
    return single_mesh(scene)


def claims(scene) -> bool:
    return _mesh(scene) is not None


def supports(engine, scene, integrator):
    if scene.part_kinds() != {"meshes"}:
        return (f"refsim fem: one mesh alone, got also "
                f"{', '.join(sorted(scene.part_kinds() - {'meshes'}))}")
    static = scene.meta.get("solve") == "static"
    name = spec_name(integrator)
    if name and static and name != "steady":
        return ("refsim fem: the scene asks for its static equilibrium (meta solve = static), "
                "solved by 'steady', not stepped by " + name)
    if name and not static and name not in STEPPERS:
        return f"refsim fem steps a dynamic scene with {', '.join(STEPPERS)}, not {name}"
    if scene.contact is not None:
        return "refsim fem: no contact (the mesh is alone)"
    return None


class StaticSim(Sim):
    """The mesh's static equilibrium, solved afresh from its initial positions every step."""

    def __init__(self, scene, dt, formulation=""):
        self.dt, self.mesh = float(dt), _mesh(scene)
        self.system = FemSystem(self.mesh, scene.gravity, formulation=formulation)
        self.x = self.system.full_positions(self.system.state()[0])
        self.residual, self.iterations = float("nan"), 0

    def _step_impl(self, n):
        system, body = self.system, self.system.body
        external = np.zeros((system.n_nodes, 3))
        external[system.free] = system.external
        fixed = np.broadcast_to(~system.free[:, None], (system.n_nodes, body.d))
        for _ in range(n):  # every step the same complete solve from the initial positions
            x0 = body.to_local(system.full_positions(system.state()[0]))
            result = solve_static(body, body.to_local(external), fixed, x0, rtol=NEWTON_RTOL,
                                  assembler=system.assembler)
            self.x = body.to_world(result.x)
            self.residual, self.iterations = float(result.residual), int(result.iterations)

    def _observe(self):
        return {"x": self.x.copy(), "v": np.zeros_like(self.x),
                "residual": self.residual, "iterations": self.iterations}

    def settings(self):
        return {"integrator": dict(STEADY), "dtype": "float64", "threads": 1,
                "model": self.system.describe(), "newton_rtol": NEWTON_RTOL,
                "solver": "Newton on the free dofs, scipy.sparse.linalg.spsolve (SuperLU) of "
                          "the tangent stiffness; stops at max |residual| <= newton_rtol x "
                          "the force scale or at the positions' round-off",
                "step": "one complete static solve from the initial positions"}


class DynamicSim(SteppedSim):
    def __init__(self, scene, dt, integrator, formulation=""):
        system = FemSystem(_mesh(scene), scene.gravity, formulation=formulation)
        super().__init__(dt, get_integrator(integrator), system, *system.state())

    def _step_impl(self, n):
        if self.system.plastic_strain is None:
            return super()._step_impl(n)
        with np.errstate(all="ignore"):
            self.stepper_t, self.state = self.system.advance(
                self.stepper, self.stepper_t, self.state, self.dt, n)

    def stages(self):
        return ["elastic_forces", "loads_and_gravity", f"integrate:{self.stepper.name}"]

    def _observe(self):
        x, v = self.coordinates()
        return {"x": self.system.full_positions(x), "v": self.system.full_velocities(v)}

    def settings(self):
        return {**self.base_settings(), "model": self.system.describe()}


def formulations(engine, scene):
    return ("", fem_printed.FORMULATION)


def build(engine, scene, dt, integrator, formulation):
    if integrator == "steady":
        return StaticSim(scene, dt, formulation)
    return DynamicSim(scene, dt, integrator, formulation)


MODEL_GROUP = ModelGroup(name="fem", build=build, claims=claims,
                         parts=frozenset({"meshes"}),
                         features=frozenset({"fem", "gravity", "plasticity"}),
                         supports=supports, formulations=formulations,
                         integrators=INTEGRATORS)
