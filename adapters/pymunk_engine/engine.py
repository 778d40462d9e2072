"""PymunkEngine: what pymunk simulates of a scene, its variants, and which scenes it refuses."""
from __future__ import annotations

import numpy as np

from refsim.engine import Engine

from ..common.checks import non_sphere_bodies, walls_without_contact
from .plane import Plane

JOINT_VARIANTS = ("", "default_bias")
DRAG_VARIANTS = ("", "space_damping")


class PymunkEngine(Engine):
    name = "pymunk"
    package = "pymunk"
    parts = frozenset({"particles", "springs", "joints", "walls"})
    capabilities = frozenset({"gravity", "springs", "joints", "drag", "contacts", "walls"})
    dims = (2, 3)
    integrators = ("symplectic_euler_dk",)

    def _supports(self, scene, integrator):
        reason = _plane_support(scene)
        if reason:
            return reason
        if scene.contact is None:
            return walls_without_contact(scene, "pymunk", " to collide with")
        return non_sphere_bodies(scene, "pymunk")

    def variants(self, scene):
        """`default_bias` keeps pymunk's own PinJoint error_bias
        (docs/engine_notes.md#pymunk-joint-bias-loses-energy: it loses energy); `space_damping`
        uses pymunk's multiplicative global damping for drag."""
        if scene.joints:
            return JOINT_VARIANTS
        if scene.linear_drag > 0 and len(set(scene.masses)) == 1:
            return DRAG_VARIANTS
        return ("",)

    def _build(self, scene, dt, integrator, variant):
        import pymunk  # lazily: refsim works without pymunk installed

        from .sim import PymunkSim
        return PymunkSim(pymunk, scene, dt, variant)


def _plane_support(scene):
    """None when every motion stays in pymunk's plane, else why not."""
    if scene.dim == 3 and not scene.stays_in_xz_plane():
        if scene.contact is not None:
            return ("pymunk is 2D: these spheres move in 3D (positions, velocities or wall "
                    "normals off the x-z plane, e.g. the box), which a 2D engine cannot "
                    "simulate")
        return ("pymunk is 2D: it takes a 3D scene only when all motion stays in the x-z "
                "plane (y = 0, no y velocity, gravity or anchor offset, hinge axes along y)")
    if scene.dim == 2 and not scene.stays_in_plane(2):
        return ("pymunk is 2D: a 2D scene must have zero z components (positions, "
                "velocities, gravity, anchors) and hinge axes along z")
    normal = Plane(scene.dim).normal_axis
    if any(np.delete(b.angular_velocity, normal).any() for b in scene.bodies):
        return "pymunk is 2D: bodies may only spin about the axis normal to the plane"
    return None
