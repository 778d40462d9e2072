"""PymunkEngine: who the pymunk adapter is (name, package, dimensions, its one integrator) and
why it refuses the scene kinds none of its model groups runs (`refusals`). What it runs is its
model groups, adapters/pymunk_engine/groups/: particles, spheres, gravity_pairs, pivots,
rolling (contact_rolling.py) and spring_network."""
from __future__ import annotations

from refsim.engine import Engine

from ..common.grid_pde import grid_refusal_sentence

# scene kinds no group runs: pymunk is a 2D rigid-body engine with point masses, circles,
# segments, springs and constraints only (these sentences are the ones its parts check gave)
NOT_SIMULATED = ("emitter", "flocking", "fluid", "lennard_jones", "meshes", "surface_sampling",
                 "velocity_field")


class PymunkEngine(Engine):
    name = "pymunk"
    package = "pymunk"
    dims = (2, 3)
    integrators = ("symplectic_euler_dk",)
    refusals = {
        # collision queries (issue 28) of 3D shapes: pymunk is 2D
        **dict.fromkeys(("box_pairs", "sdf_probes", "bvh_queries", "sphere_sweeps"),
                        "pymunk is a 2D engine: the query is on 3D shapes"),
        "prescribed_flow": "pymunk has no prescribed-flow advection (massless tracers or a "
                           "level set moved by an analytic velocity field)",
        **{kind: f"pymunk does not simulate {kind}" for kind in NOT_SIMULATED},
        # keyed on the heat, wave and Poisson grids' features (what the sentence names), not
        # on the part kind "grids" the level sets share: Engine.refusal takes part kinds
        # first, so a level set moved by a prescribed flow gets that sentence
        **dict.fromkeys(("diffusion", "poisson", "wave"), grid_refusal_sentence(
            "pymunk", "it is a 2D rigid-body engine")),
        "fluid_grids": ("pymunk has no grid fluid solver (no MAC grid, advection or pressure "
                        "projection; it is a 2D rigid-body engine)"),
        # free rigid bodies; those with shapes on walls are the rolling group, pivoted ones the
        # pivots group
        "rigid": ("pymunk is 2D: free rigid bodies here turn about a tilted or changing axis "
                  "in 3D (a body's angle in a plane cannot hold it)"),
    }
