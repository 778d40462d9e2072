"""The pybullet engine: who it is, and why it refuses the scene kinds none of its model groups
runs.

pybullet steps with semi-implicit Euler, velocities then positions ("kick-drift", refsim's
`symplectic_euler`). What it runs is its model groups (groups/): particles (Featherstone
multibodies without contacts: point masses, rods, springs and drag), spheres (rigid spheres and
static walls with contacts), gravity_pairs, rigid, pivots, rolling (contact_rolling.py) and
spring_network, and fem (one tetrahedral Neo-Hookean mesh). Every other scene is refused from
`refusals`: grids (no finite-difference solver), an SPH fluid, the particle fields pybullet has
no model of, and several meshes in one scene.
"""
from __future__ import annotations

from refsim.engine import Engine

from ..common.grid_pde import grid_refusal_sentence
from .runtime import import_pybullet

# part kinds refused with "pybullet does not simulate <kind>" (pybullet has no SPH, no pair
# potentials or flocking rules, no particle fields)
NOT_SIMULATED = ("emitter", "flocking", "fluid", "lennard_jones", "surface_sampling",
                 "velocity_field")


class PybulletEngine(Engine):
    name = "pybullet"
    package = "pybullet"
    dims = (3,)
    integrators = ("symplectic_euler",)
    refusals = {
        # collision queries (issue 28) pybullet has no call for
        "polygon_pairs": "pybullet is a 3D engine: no 2D polygon shapes (an extruded prism "
                         "would answer a different question at its caps)",
        "sdf_probes": "pybullet exposes no query of a grid signed distance field",
        "bvh_queries": "pybullet exposes only an AABB broad-phase query "
                       "(getOverlappingObjects), not a sphere overlap or nearest query",
        "sphere_sweeps": "pybullet has no public time-of-impact call (ccdSweptSphereRadius "
                         "acts inside stepSimulation)",
        "prescribed_flow": "pybullet has no prescribed-flow advection (massless tracers or a "
                           "level set moved by an analytic velocity field)",
        # keyed on the heat, wave and Poisson grids' features (what the sentence names), not
        # on the part kind "grids" the level sets share: Engine.refusal takes part kinds
        # first, so a level set moved by a prescribed flow gets that sentence
        **dict.fromkeys(("diffusion", "poisson", "wave"), grid_refusal_sentence(
            "pybullet", "it simulates rigid bodies, multibodies and soft-body meshes")),
        "fluid_grids": ("pybullet has no grid fluid solver (no MAC grid, advection or pressure "
                        "projection; it simulates rigid bodies, multibodies, soft meshes)"),
        **{kind: f"pybullet does not simulate {kind}" for kind in NOT_SIMULATED},
        # a scene of one mesh goes to the fem group (groups/fem.py), which says why it
        # refuses the meshes it cannot run; only a scene of several meshes reaches this line
        "meshes": ("pybullet fem: one mesh per scene (a TetMesh of the neo_hookean law as "
                   "pybullet's deformable body), got several"),
    }

    def available(self) -> bool:
        try:
            import_pybullet()
        except ImportError:
            return False
        return True
