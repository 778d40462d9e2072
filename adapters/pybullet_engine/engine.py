"""The pybullet engine: what it simulates, what it refuses and why, and the build.

pybullet steps with semi-implicit Euler, velocities then positions ("kick-drift", refsim's
`symplectic_euler`): Featherstone multibodies without contacts (multibodies.py), rigid
spheres and static walls with contacts (contacts.py), springs and drag as external forces
(forces.py).
"""
from __future__ import annotations

from refsim.engine import Engine

from .contacts import contact_mismatch
from .multibodies import rods_mismatch
from .runtime import import_pybullet
from .sim import PybulletSim


class PybulletEngine(Engine):
    name = "pybullet"
    package = "pybullet"
    parts = frozenset({"particles", "springs", "joints", "walls"})
    capabilities = frozenset({"gravity", "springs", "joints", "drag", "contacts", "walls"})
    dims = (3,)
    integrators = ("symplectic_euler",)

    def available(self) -> bool:
        try:
            import_pybullet()
        except ImportError:
            return False
        return True

    def _supports(self, scene, integrator):
        if integrator is not None and integrator != "symplectic_euler":
            return f"pybullet's symplectic_euler takes no parameter, got {integrator!r}"
        return rods_mismatch(scene) or contact_mismatch(scene)

    def _build(self, scene, dt, integrator, variant):
        return PybulletSim(import_pybullet(), scene, dt)
