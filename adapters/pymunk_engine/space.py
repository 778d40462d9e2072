"""The pymunk Space built from a scene: bodies, circles, wall segments, springs and joints.

docs/engine_notes.md#pymunk facts applied (pymunk 7.3.1): no damping, zero gravity unless the
scene sets it, 10 iterations, mass and moment > 0 with moment = inf for a point mass, springs as
`DampedSpring`, the `PinJoint` bias made explicit, elasticity and friction multiplied per pair.
"""
from __future__ import annotations

import math

import numpy as np

from ..common.contacts import per_shape_coefficients

ITERATIONS = 10  # pymunk's default, kept; one constraint per body is solved in the first pass
# Contact position correction off: collision_bias = 1 makes the bias coefficient 1 - 1^h = 0,
# so positions move only with the velocities (a pure impulse model); slop 0 is then inert.
# pymunk's defaults (kept in PYMUNK_DEFAULTS for the report) are slop 0.1 (a pixel-scale
# length, the spheres' radius here) and bias 0.9^60 = 1.797e-3.
COLLISION_BIAS, COLLISION_SLOP = 1.0, 0.0
PYMUNK_DEFAULTS = {"collision_slop": 0.1, "collision_bias": 0.9 ** 60,
                   "collision_persistence": 3, "iterations": 10}
WALL_HALF_LENGTH = 100.0  # wall segments span +- this many scene sizes around the wall point


def make_space(pymunk, scene, variant, gravity):
    """A fresh space: gravity from the scene (pymunk's default is zero), damping 1.0 (none)
    unless drag is mapped to pymunk's global damping, the 10 iterations of
    docs/engine_notes.md#pymunk-space-defaults, unthreaded, contact position correction off
    (see COLLISION_BIAS)."""
    space = pymunk.Space(threaded=False)
    space.iterations = ITERATIONS
    space.gravity = gravity
    space.damping = 1.0
    space.collision_bias, space.collision_slop = COLLISION_BIAS, COLLISION_SLOP
    if variant == "space_damping":
        space.damping = math.exp(-scene.linear_drag / scene.bodies[0].mass)
    return space


def make_body(pymunk, body, plane):
    """docs/engine_notes.md#pymunk-mass-and-moment (pymunk 7.3.1): mass and moment must be
    > 0; moment = inf for a point mass (no rotation to integrate). A sphere's moment is the
    scene's inertia (2/5 m r^2), set here and never recomputed: its circle shape carries no
    mass or density."""
    moment = body.inertia if body.inertia > 0 else math.inf
    pb = pymunk.Body(body.mass, moment)
    pb.position, pb.velocity = plane.to2d(body.position), plane.to2d(body.velocity)
    pb.angular_velocity = plane.spin_sign * body.angular_velocity[plane.normal_axis]
    return pb


def make_circles(pymunk, bodies, scene):
    """One Circle per sphere, carrying sqrt(e) and sqrt(mu): Chipmunk multiplies the two
    shapes' coefficients per contact (cpArbiterUpdate: e = a.e * b.e, u = a.u * b.u; measured:
    0.5 on each gives e = 0.25), so the pair's product is e (mu) to 1 ulp
    (adapters.common.contacts.per_shape_coefficients)."""
    e, mu = per_shape_coefficients(scene.contact)
    circles = []
    for pb, body in zip(bodies, scene.bodies):
        circle = pymunk.Circle(pb, body.radius)
        circle.elasticity, circle.friction = e, mu
        circles.append(circle)
    return circles


def wall_half_length(scene):
    """Half-length of a wall segment: pymunk has no half-plane, so a wall is a static
    segment spanning WALL_HALF_LENGTH scene sizes (bodies' spread about the wall points)."""
    pts = np.array([b.position for b in scene.bodies] + [w.point for w in scene.walls])
    size = max(1.0, float(np.ptp(pts, axis=0).max()))
    return WALL_HALF_LENGTH * size


def make_wall(pymunk, space, wall, scene, plane):
    """A Segment (radius 0) on the static body along the wall line, with the same sqrt(e),
    sqrt(mu) as the circles so a sphere-wall contact gets e and mu. Two-sided: the
    scene's inward normal only says where the spheres are."""
    p, n = np.array(plane.to2d(wall.point)), np.array(plane.to2d(wall.normal))
    t = np.array([-n[1], n[0]]) / np.linalg.norm(n) * wall_half_length(scene)
    seg = pymunk.Segment(space.static_body, tuple(p - t), tuple(p + t), 0.0)
    seg.elasticity, seg.friction = per_shape_coefficients(scene.contact)
    return seg


def add_spring(pymunk, space, bodies, spring, plane):
    """DampedSpring: force k (L0 - d) along the axis; damping c on the relative velocity
    along the axis (Munk2D src/cpDampedSpring.c). An end is a body's centre, or a world
    point on the static body (at the origin, unrotated, so local = world)."""
    if spring.other is None:
        a, anchor_a = space.static_body, plane.to2d(spring.anchor)
    else:
        a, anchor_a = bodies[spring.other], (0.0, 0.0)
    ps = pymunk.DampedSpring(a, bodies[spring.body], anchor_a, (0.0, 0.0), spring.rest_length,
                             spring.stiffness, spring.damping)
    space.add(ps)
    return ps


def add_joint(pymunk, space, bodies, joint, plane, variant):
    """PinJoint from the static body at the anchor to the bob, distance = rod length.
    error_bias = 0 (default variant) makes the bias coefficient 1 - 0^h = 1: each step's
    velocity carries the full rod-length correction -(d - L)/h (src/cpPinJoint.c)."""
    pj = pymunk.PinJoint(space.static_body, bodies[joint.body], plane.to2d(joint.anchor),
                         (0.0, 0.0))
    pj.distance = joint.length
    if variant != "default_bias":
        pj.error_bias = 0.0
    space.add(pj)
    return pj
