"""The in-house engine's SPH group: a 2D weakly compressible fluid block in a tank
(`sph.FluidSim`), stepped kick-drift-kick (`velocity_verlet` only)."""
from __future__ import annotations

from refsim.engine import ModelGroup


def claims(scene) -> bool:
    return "fluid" in scene.part_kinds() and scene.contact is None


def _supports(engine, scene, integrator):
    if integrator not in (None, "velocity_verlet"):
        return "refsim fluid scenes step with kick-drift-kick SPH ('velocity_verlet')"
    return None


def _build(engine, scene, dt, integrator, formulation):
    from ..sph import FluidSim
    return FluidSim(scene, dt)


MODEL_GROUP = ModelGroup(
    name="sph", claims=claims, parts=frozenset({"fluid", "walls"}),
    features=frozenset({"gravity", "drag", "walls", "fluid"}), supports=_supports,
    build=_build)
