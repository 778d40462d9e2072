"""The in-house engine's spring-network group (slides 000-002): cloth, rope and hair as one
`SpringNetwork` (stretch springs with damping, hinge and dihedral bending, air drag, gravity,
pinned nodes; refsim.models.spring_network) advanced by refsim's own steppers on the free
nodes: symplectic Euler, velocity Verlet, RK4 and Baraff-Witkin, and the drift-kick symplectic
Euler (`symplectic_euler_dk`), pymunk's own step, so pymunk's rows have an in-house twin.

Formulations (named alternatives of one model) choose Baraff-Witkin's linear solve where it is sparse (a state
of SPARSE_MIN entries or more): "" = SuperLU (scipy.sparse.linalg.spsolve), "cg" = conjugate
gradient to relative residual CG_RTOL. Smaller networks solve densely, and offer no "cg".
Observes x and v of every node (pinned ones included).
"""
from __future__ import annotations

from refsim_adapters.common.spring_network import (
    NETWORK_INTEGRATORS,
    claims,
    integrator_reason,
    observation,
    scene_reason,
    solve_formulations,
)
from refsim.engine import ModelGroup
from refsim.integrators import BaraffWitkin, get_integrator
from refsim.integrators.implicit import SPARSE_MIN
from refsim.models.spring_network import NetworkSystem
from refsim.scene import SpringNetwork

from ..stepped import SteppedSim

INTEGRATORS = NETWORK_INTEGRATORS + ("symplectic_euler_dk",)
CG_RTOL = 1e-10  # relative residual of Baraff-Witkin's CG: well below every case's tolerance
FORMULATIONS = {"": "sparse direct (SuperLU)", "cg": f"conjugate gradient, rtol {CG_RTOL:g}"}


class NetworkSim(SteppedSim):
    def __init__(self, scene, dt, integrator, variant):
        self.variant = variant
        stepper = (BaraffWitkin("cg" if variant == "cg" else "direct", CG_RTOL)
                   if integrator == "baraff_witkin" else get_integrator(integrator))
        system = NetworkSystem(scene.part(SpringNetwork), scene.gravity, scene.linear_drag)
        free = system.free
        super().__init__(dt, stepper, system, scene.part(SpringNetwork).positions[free].reshape(-1),
                         scene.part(SpringNetwork).velocities[free].reshape(-1))

    def stages(self):
        kinds = sorted(self.system.net.edge_kinds())
        return ["gravity", *kinds] + (["drag"] if self.system.drag > 0 else []) + \
            [f"integrate:{self.stepper.name}"]

    def _observe(self):
        x, v = self.coordinates()
        return observation(self.system.full_positions(x), self.system.full_velocities(v))

    def settings(self):
        sparse = self.system.nbody * 3 >= SPARSE_MIN
        solve = ("none (explicit)" if self.stepper.explicit else
                 FORMULATIONS[self.variant] if sparse else "dense numpy.linalg.solve "
                 f"(state below {SPARSE_MIN} entries)")
        return {**self.base_settings(), "model": self.system.describe(), "solve": solve,
                "formulation": FORMULATIONS[self.variant]}


def supports(engine, scene, integrator):
    return scene_reason(scene, "refsim") or integrator_reason(integrator, INTEGRATORS)


def formulations(engine, scene):
    return solve_formulations(scene)


def build(engine, scene, dt, integrator, formulation):
    return NetworkSim(scene, dt, integrator, formulation)


MODEL_GROUP = ModelGroup(name="spring_network", build=build, claims=claims,
                         parts=frozenset({"networks"}),
                         features=frozenset({"networks", "gravity", "drag"}),
                         supports=supports, formulations=formulations, integrators=INTEGRATORS)
