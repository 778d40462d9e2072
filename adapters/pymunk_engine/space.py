"""The pymunk Space of a particle scene: bodies, circles, wall segments, springs and joints,
each built from the arrays of the part the model group passes (never from the scene's kinds).

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


def make_space(pymunk, gravity, damping=1.0):
    """A fresh space: gravity from the scene (pymunk's default is zero), damping 1.0 (none)
    unless the caller maps drag onto pymunk's global damping, the 10 iterations of
    docs/engine_notes.md#pymunk-space-defaults, unthreaded, contact position correction off
    (see COLLISION_BIAS)."""
    space = pymunk.Space(threaded=False)
    space.iterations = ITERATIONS
    space.gravity = gravity
    space.damping = damping
    space.collision_bias, space.collision_slop = COLLISION_BIAS, COLLISION_SLOP
    return space


def make_bodies(pymunk, particles, plane):
    """One pymunk.Body per particle (build time: pymunk takes one body per call).
    docs/engine_notes.md#pymunk-mass-and-moment (pymunk 7.3.1): mass and moment must be > 0;
    moment = inf for a point mass (no rotation to integrate). A sphere's moment is the scene's
    inertia (2/5 m r^2), set here and never recomputed: its circle shape carries no mass or
    density."""
    out = []
    rows = zip(particles.mass, particles.inertia, particles.position, particles.velocity,
               particles.angular_velocity)
    for mass, inertia, position, velocity, spin in rows:
        pb = pymunk.Body(float(mass), float(inertia) if inertia > 0 else math.inf)
        pb.position, pb.velocity = plane.to2d(position), plane.to2d(velocity)
        pb.angular_velocity = plane.spin_sign * spin[plane.normal_axis]
        out.append(pb)
    return out


def make_circles(pymunk, bodies, radii, contact):
    """One Circle per sphere, carrying sqrt(e) and sqrt(mu): Chipmunk multiplies the two
    shapes' coefficients per contact (cpArbiterUpdate: e = a.e * b.e, u = a.u * b.u; measured:
    0.5 on each gives e = 0.25), so the pair's product is e (mu) to 1 ulp
    (adapters.common.contacts.per_shape_coefficients)."""
    e, mu = per_shape_coefficients(contact)
    circles = []
    for pb, radius in zip(bodies, radii):
        circle = pymunk.Circle(pb, float(radius))
        circle.elasticity, circle.friction = e, mu
        circles.append(circle)
    return circles


def wall_half_length(positions, wall_points):
    """Half-length of a wall segment: pymunk has no half-plane, so a wall is a static
    segment spanning WALL_HALF_LENGTH scene sizes (bodies' spread about the wall points)."""
    pts = np.vstack([np.reshape(positions, (-1, 3)), np.reshape(wall_points, (-1, 3))])
    size = max(1.0, float(np.ptp(pts, axis=0).max()))
    return WALL_HALF_LENGTH * size


def make_wall(pymunk, space, point, normal, half_length, contact, plane):
    """A Segment (radius 0) on the static body along the wall line, with the same sqrt(e),
    sqrt(mu) as the circles so a sphere-wall contact gets e and mu. Two-sided: the
    scene's inward normal only says where the spheres are."""
    p, n = np.array(plane.to2d(point)), np.array(plane.to2d(normal))
    t = np.array([-n[1], n[0]]) / np.linalg.norm(n) * half_length
    seg = pymunk.Segment(space.static_body, tuple(p - t), tuple(p + t), 0.0)
    seg.elasticity, seg.friction = per_shape_coefficients(contact)
    return seg


def add_springs(pymunk, space, bodies, springs, plane):
    """One DampedSpring per spring: force k (L0 - d) along the axis; damping c on the relative
    velocity along the axis (Munk2D src/cpDampedSpring.c). An end is a body's centre, or a
    world point on the static body (at the origin, unrotated, so local = world): other < 0."""
    out = []
    rows = zip(springs.body, springs.other, springs.anchor, springs.rest_length,
               springs.stiffness, springs.damping)
    for body, other, anchor, rest_length, stiffness, damping in rows:
        if other < 0:
            a, anchor_a = space.static_body, plane.to2d(anchor)
        else:
            a, anchor_a = bodies[int(other)], (0.0, 0.0)
        ps = pymunk.DampedSpring(a, bodies[int(body)], anchor_a, (0.0, 0.0), float(rest_length),
                                 float(stiffness), float(damping))
        space.add(ps)
        out.append(ps)
    return out


def add_joints(pymunk, space, bodies, joints, plane, default_bias):
    """One PinJoint per rod, from the static body at the anchor to the bob, distance = rod
    length. error_bias = 0 (unless `default_bias`) makes the bias coefficient 1 - 0^h = 1: each
    step's velocity carries the full rod-length correction -(d - L)/h (src/cpPinJoint.c)."""
    out = []
    for body, anchor, length in zip(joints.body, joints.anchor, joints.length):
        pj = pymunk.PinJoint(space.static_body, bodies[int(body)], plane.to2d(anchor),
                             (0.0, 0.0))
        pj.distance = float(length)
        if not default_bias:
            pj.error_bias = 0.0
        space.add(pj)
        out.append(pj)
    return out
