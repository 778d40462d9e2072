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
        # collision queries (issue 28) MuJoCo has no call for
        "polygon_pairs": "mujoco is a 3D engine: no 2D polygon geoms",
        "sdf_probes": "mujoco exposes no query of a grid signed distance field's value or "
                      "gradient (its SDF geoms are collision plugins)",
        "bvh_queries": "mujoco exposes no BVH query (its broad phase runs inside mj_collision "
                       "on the model's geoms only)",
        "sphere_sweeps": "mujoco has no public time-of-impact call (conservative advancement "
                         "acts inside mj_step with the speculative flag)",
        # keyed on the heat, wave and Poisson grids' features (what the sentence names), not
        # on the part kind "grids" the level sets share: Engine.refusal takes part kinds
        # first, so a level set moved by a prescribed flow gets that sentence
        **dict.fromkeys(("diffusion", "poisson", "wave"), grid_refusal_sentence(
            "mujoco", "it simulates multibody dynamics, with flex meshes for soft bodies")),
        "prescribed_flow": "mujoco has no prescribed-flow advection (massless tracers or a "
                           "level set moved by an analytic velocity field)",
        "fluid": "mujoco does not simulate fluid",  # MuJoCo has no SPH
        # the fem group (MuJoCo 4 flex, StVK) claims a scene of exactly one mesh
        "meshes": "the mujoco adapter's fem group runs one mesh per scene (a MuJoCo 4 flex); "
                  "several meshes are not offered",
        "emitter": "mujoco does not simulate emitter",
        "fluid_grids": ("mujoco has no grid fluid solver (no MAC grid, advection or pressure "
                        "projection; it simulates multibody dynamics and flex meshes)"),
    }

    def build(self, scene, dt, integrator, formulation=""):
        """MuJoCo integrators are exact names (the base also accepts "name:parameter" and
        None), or a name the scene's model group offers ("steady" of the fem group): an
        unknown one is refused first, then the base validates dt, formulation and support."""
        allowed = set(METHODS) | set(self.offered_integrators(scene))
        if integrator not in allowed:
            raise ValueError(f"mujoco integrator must be one of {sorted(allowed)}, "
                             f"got {integrator!r}")
        return super().build(scene, dt, integrator, formulation)
