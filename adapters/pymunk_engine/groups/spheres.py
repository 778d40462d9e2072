"""pymunk's spheres group: spheres under a contact model (scene.contact), with walls or not, in
pymunk's plane; springs, rods and drag as in the particles group (groups/particles.py), whose
plane check and formulations this group shares.

Each sphere is a `pymunk.Body` with the scene's moment of inertia and a `Circle` carrying
sqrt(e) and sqrt(mu) (Chipmunk multiplies the pair's coefficients); each wall a static
`Segment`; contact position correction off (adapters/pymunk_engine/space.py). The step is
cpSpaceStep with discrete detection at the drifted positions and Newton's restitution with
Coulomb friction in the impulse passes (adapters/pymunk_engine/__init__.py). pymunk is 2D: a
scene whose spheres move in 3D (the box) is refused; every body must be a sphere (radius > 0).
"""
from __future__ import annotations

from refsim.engine import ModelGroup
from refsim.scene import Joints, Particles, Springs, Walls

from ...common.checks import non_sphere_bodies
from .particles import FEATURES, INTEGRATORS, PARTS, formulations, particle_scene, plane_reason

OFF_XZ_PLANE = ("pymunk is 2D: these spheres move in 3D (positions, velocities or wall "
                "normals off the x-z plane, e.g. the box), which a 2D engine cannot "
                "simulate")


def claims(scene) -> bool:
    return scene.contact is not None and particle_scene(scene)


def supports(engine, scene, integrator):
    return plane_reason(scene, OFF_XZ_PLANE) or non_sphere_bodies(scene, "pymunk")


def build(engine, scene, dt, integrator, formulation):
    import pymunk  # lazily: refsim works without pymunk installed

    from ..sim import PymunkSim
    return PymunkSim(pymunk, scene, dt, formulation, scene.part(Particles),
                     springs=scene.part(Springs), joints=scene.part(Joints),
                     contact=scene.contact, walls=scene.part(Walls))


MODEL_GROUP = ModelGroup(name="spheres", build=build, claims=claims, parts=PARTS,
                         features=FEATURES | {"contacts"}, supports=supports,
                         formulations=formulations, integrators=INTEGRATORS)
