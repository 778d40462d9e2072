"""pymunk's spheres group: spheres under a contact model (scene.contact), with walls or not, in
pymunk's plane; springs, rods and drag as in the particles group (groups/particles.py), whose
plane check and formulations this group shares.

Each sphere is a `pymunk.Body` with the scene's moment of inertia and a `Circle` carrying
sqrt(e) and sqrt(mu) (Chipmunk multiplies the pair's coefficients); each wall a static
`Segment`; contact position correction off (adapters/pymunk_engine/space.py). The step is
cpSpaceStep with discrete detection at the drifted positions and Newton's restitution with
Coulomb friction in the impulse passes (adapters/pymunk_engine/__init__.py). pymunk is 2D: a
scene whose spheres move in 3D (the box) is refused; every body must be a sphere (radius > 0).
Thin static plates (the Plates part) lying across pymunk's plane are static rectangles
(adapters/pymunk_engine/plates.py); pymunk has no continuous detection, so one formulation.
"""
from __future__ import annotations

from refsim.engine import ModelGroup
from refsim.scene import Joints, Particles, Plates, Springs, Walls

from ...common.checks import non_sphere_bodies
from ..plane import Plane
from .particles import FEATURES, INTEGRATORS, PARTS, formulations, plane_reason

SPHERE_PARTS = PARTS | {"plates"}

OFF_XZ_PLANE = ("pymunk is 2D: these spheres move in 3D (positions, velocities or wall "
                "normals off the x-z plane, e.g. the box), which a 2D engine cannot "
                "simulate")


def claims(scene) -> bool:
    """Particles (springs, rods, walls, plates or not) under a contact model, or with plates
    (refused without one)."""
    kinds = scene.part_kinds()
    return "particles" in kinds and kinds <= SPHERE_PARTS and \
        (scene.contact is not None or "plates" in kinds)


def supports(engine, scene, integrator):
    plates = scene.part(Plates)
    if plates is not None:
        from ..plates import plane_reason as plates_reason
        if scene.contact is None:
            return ("pymunk: plates without a contact model (nothing says how spheres "
                    "bounce off them)")
        reason = plates_reason(scene, plates, Plane(scene.dim).normal_axis)
        if reason:
            return reason
    return plane_reason(scene, OFF_XZ_PLANE) or non_sphere_bodies(scene, "pymunk")


def build(engine, scene, dt, integrator, formulation):
    import pymunk  # lazily: refsim works without pymunk installed

    from ..sim import PymunkSim
    parts = dict(springs=scene.part(Springs), joints=scene.part(Joints),
                 contact=scene.contact, walls=scene.part(Walls))
    if scene.part(Plates) is not None:
        from ..plates import PlatesSim
        return PlatesSim(pymunk, scene, dt, formulation, scene.part(Particles),
                         scene.part(Plates), **parts)
    return PymunkSim(pymunk, scene, dt, formulation, scene.part(Particles), **parts)


MODEL_GROUP = ModelGroup(name="spheres", build=build, claims=claims, parts=SPHERE_PARTS,
                         features=FEATURES | {"contacts", "plates"}, supports=supports,
                         formulations=formulations, integrators=INTEGRATORS)
