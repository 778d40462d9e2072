"""pymunk's particles group: point masses (or spheres that never touch: no contact model) in
pymunk's plane, with springs, rods (joints) and linear drag. Spheres under a contact model are
the spheres group (groups/spheres.py), which shares this module's plane check and formulations.

pymunk is 2D: a 3D scene is taken when all motion stays in its x-z plane, a 2D scene when it
stays in its x-y plane (adapters/pymunk_engine/plane.py); bodies spin only about the plane's
normal. Walls without a contact model are refused (nothing says how bodies bounce off them).
Each particle is a `pymunk.Body` (moment inf for a point mass), each spring a `DampedSpring`,
each rod a `PinJoint` from the static body (adapters/pymunk_engine/space.py); the step is
cpSpaceStep, refsim's `symplectic_euler_dk` (adapters/pymunk_engine/__init__.py).

Formulations: with rods, "" (error_bias = 0) and "default_bias" (pymunk's own PinJoint bias,
docs/engine_notes.md#pymunk-joint-bias-loses-energy: it loses energy); with drag on bodies of
one mass, "" (the force -b v) and "space_damping" (pymunk's multiplicative global damping).
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup
from refsim.scene import Joints, Particles, Springs

from ...common.checks import walls_without_contact
from ..plane import Plane

PARTS = frozenset({"particles", "springs", "joints", "walls"})
FEATURES = frozenset({"gravity", "springs", "joints", "drag", "walls"})
INTEGRATORS = ("symplectic_euler_dk",)
JOINT_FORMULATIONS = ("", "default_bias")
DRAG_FORMULATIONS = ("", "space_damping")
OFF_XZ_PLANE = ("pymunk is 2D: it takes a 3D scene only when all motion stays in the x-z "
                "plane (y = 0, no y velocity, gravity or anchor offset, hinge axes along y)")


def particle_scene(scene) -> bool:
    """Particles with nothing beside them but springs, rods and walls (the parts pymunk's
    particle space holds)."""
    return "particles" in scene.part_kinds() and scene.part_kinds() <= PARTS


def claims(scene) -> bool:
    return scene.contact is None and particle_scene(scene)


def plane_reason(scene, off_xz_plane: str) -> str | None:
    """None when every motion stays in pymunk's plane, else why not (`off_xz_plane`: the
    sentence for a 3D scene leaving its x-z plane)."""
    if scene.dim == 3 and not scene.stays_in_xz_plane():
        return off_xz_plane
    if scene.dim == 2 and not scene.stays_in_plane(2):
        return ("pymunk is 2D: a 2D scene must have zero z components (positions, "
                "velocities, gravity, anchors) and hinge axes along z")
    normal = Plane(scene.dim).normal_axis
    if np.delete(scene.part(Particles).angular_velocity, normal, axis=1).any():
        return "pymunk is 2D: bodies may only spin about the axis normal to the plane"
    return None


def supports(engine, scene, integrator):
    return (plane_reason(scene, OFF_XZ_PLANE)
            or walls_without_contact(scene, "pymunk", " to collide with"))


def formulations(engine, scene):
    """`default_bias` keeps pymunk's own PinJoint error_bias
    (docs/engine_notes.md#pymunk-joint-bias-loses-energy: it loses energy); `space_damping`
    uses pymunk's multiplicative global damping for drag (bodies of one mass)."""
    if scene.part(Joints) is not None:
        return JOINT_FORMULATIONS
    if scene.linear_drag > 0 and len(set(scene.part(Particles).mass)) == 1:
        return DRAG_FORMULATIONS
    return ("",)


def build(engine, scene, dt, integrator, formulation):
    import pymunk  # lazily: refsim works without pymunk installed

    from ..sim import PymunkSim
    return PymunkSim(pymunk, scene, dt, formulation, scene.part(Particles),
                     springs=scene.part(Springs), joints=scene.part(Joints))


MODEL_GROUP = ModelGroup(name="particles", build=build, claims=claims, parts=PARTS,
                         features=FEATURES, supports=supports, formulations=formulations,
                         integrators=INTEGRATORS)
