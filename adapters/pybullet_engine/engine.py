"""The pybullet engine: who it is, and why it refuses the scene kinds none of its model groups
runs.

pybullet steps with semi-implicit Euler, velocities then positions ("kick-drift", refsim's
`symplectic_euler`). What it runs is its model groups (groups/): particles (Featherstone
multibodies without contacts: point masses, rods, springs and drag), spheres (rigid spheres and
static walls with contacts), gravity_pairs, rigid, pivots, rolling (contact_rolling.py) and
spring_network. Every other scene is refused from `refusals`: grids (no finite-difference
solver), an SPH fluid and the particle fields and meshes pybullet has no model of.
"""
from __future__ import annotations

from refsim.engine import Engine

from ..common.grid_pde import grid_refusal_sentence
from .runtime import import_pybullet

# part kinds refused with "pybullet does not simulate <kind>" (pybullet has no SPH, no pair
# potentials or flocking rules, no particle fields, no FEM meshes)
NOT_SIMULATED = ("emitter", "flocking", "fluid", "lennard_jones", "meshes", "surface_sampling",
                 "velocity_field")


class PybulletEngine(Engine):
    name = "pybullet"
    package = "pybullet"
    dims = (3,)
    integrators = ("symplectic_euler",)
    refusals = {
        "grids": grid_refusal_sentence(
            "pybullet", "it simulates rigid bodies, multibodies and soft-body meshes"),
        **{kind: f"pybullet does not simulate {kind}" for kind in NOT_SIMULATED},
    }

    def available(self) -> bool:
        try:
            import_pybullet()
        except ImportError:
            return False
        return True
