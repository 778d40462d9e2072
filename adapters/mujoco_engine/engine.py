"""The MuJoCo engine: who it is (name, package, dimensions, integrators) and why it refuses the
scene kinds that none of its model groups (groups/) runs."""
from __future__ import annotations

from refsim.engine import Engine
from refsim_adapters.common.grid_pde import grid_refusal_sentence

from .methods import METHODS


class MujocoEngine(Engine):
    name = "mujoco"
    package = "mujoco"
    dims = (3,)
    integrators = tuple(METHODS)
    # the refsim stepper each method equals on an undamped spring (refsim stress's theory)
    equivalents = {"implicit": "symplectic_euler",  # damping implicit: nothing damped here
                   "implicitfast": "symplectic_euler",
                   "discrete": "implicit_euler"}  # spring stiffness and damping implicit
    # scenes with no moving particles that no group claims; particle scenes with a part MuJoCo
    # lacks (lennard_jones, flocking, ...) are the particle groups' and refused by their parts
    refusals = {
        "grids": grid_refusal_sentence(
            "mujoco", "it simulates multibody dynamics, with flex meshes for soft bodies"),
        "fluid": "mujoco does not simulate fluid",  # MuJoCo has no SPH
        "meshes": "the mujoco adapter has no finite-element group yet (MuJoCo 4 flex "
                  "elasticity: to come)",
        "emitter": "mujoco does not simulate emitter",
    }

    def build(self, scene, dt, integrator, formulation=""):
        """MuJoCo integrators are exact names (the base also accepts "name:parameter" and
        None): an unknown one is refused first, then the base validates dt, formulation and
        support."""
        if integrator not in METHODS:
            raise ValueError(f"mujoco integrator must be one of {list(METHODS)}, "
                             f"got {integrator!r}")
        return super().build(scene, dt, integrator, formulation)
