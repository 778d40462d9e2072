"""PymunkSim: one pymunk Space of particles stepped with space.step(dt) and observed in refsim's
axes. The model group (groups/particles.py, groups/spheres.py) names what the space holds: the
particles, their springs and rods (None when absent), and, for spheres under a contact model,
the contact model and the walls (circles and wall segments are built only then)."""
from __future__ import annotations

import math

import numpy as np

from refsim.engine import Sim

from ..common.hinges import rod_length_errors
from . import settings as described
from .plane import Plane
from .space import (add_joints, add_springs, make_bodies, make_circles, make_space, make_wall,
                    wall_half_length)

DEFAULT_BIAS = "default_bias"  # formulation: pymunk's own PinJoint error_bias kept
SPACE_DAMPING = "space_damping"  # formulation: drag as pymunk's global velocity damping


class PymunkSim(Sim):
    def __init__(self, pymunk, scene, dt, formulation, particles, springs=None, joints=None,
                 contact=None, walls=None):
        self.scene, self.dt, self.formulation = scene, dt, formulation
        self.contact = contact
        self.plane = plane = Plane(scene.dim)
        damping = (math.exp(-scene.linear_drag / particles.mass[0])
                   if formulation == SPACE_DAMPING else 1.0)
        self.space = space = make_space(pymunk, plane.to2d(scene.gravity), damping)
        self.bodies = make_bodies(pymunk, particles, plane)
        self.shapes = (make_circles(pymunk, self.bodies, particles.radius, contact)
                       if contact is not None else [])
        self.wall_half_length = (wall_half_length(particles.position, walls.point)
                                 if walls is not None else None)
        self.walls = ([make_wall(pymunk, space, p, n, self.wall_half_length, contact, plane)
                       for p, n in zip(walls.point, walls.normal)] if walls is not None else [])
        space.add(*self.bodies, *self.shapes, *self.walls)  # one batched add
        self.springs = (add_springs(pymunk, space, self.bodies, springs, plane)
                        if springs is not None else [])
        self.joints = (add_joints(pymunk, space, self.bodies, joints, plane,
                                  formulation == DEFAULT_BIAS) if joints is not None else [])
        # drag as the force -b v set before each step (see `_step_impl`), unless pymunk's
        # global damping carries it (formulation space_damping)
        self.drag = scene.linear_drag if formulation != SPACE_DAMPING else 0.0

    def _step_impl(self, n):
        """space.step(dt) n times: pymunk has no multi-step call, so each step is one Python
        call. Drag is the force -b v from the step-start velocity, set before the step (it is
        cleared by the velocity update), which is refsim's drift-kick a(x1, v0) exactly; it is
        one Python assignment per body per step, pymunk's API having no array access."""
        space_step, dt = self.space.step, self.dt
        if self.drag > 0:
            b, bodies = self.drag, self.bodies
            for _ in range(n):
                for body in bodies:
                    vx, vy = body.velocity
                    body.force = (-b * vx, -b * vy)
                space_step(dt)
        else:
            for _ in range(n):
                space_step(dt)

    def _observe(self):
        nb = len(self.bodies)
        x, v = np.zeros((nb, 3)), np.zeros((nb, 3))
        i, k = self.plane.axes
        for row, body in enumerate(self.bodies):
            x[row, i], x[row, k] = body.position
            v[row, i], v[row, k] = body.velocity
        out = {"x": x, "v": v}
        if self.contact is not None:  # rotation: spheres in contact can spin
            w = np.zeros((nb, 3))
            w[:, self.plane.normal_axis] = [self.plane.spin_sign * b.angular_velocity
                                            for b in self.bodies]
            out["w"] = w
        if self.joints:
            out["constraint"] = rod_length_errors(self.scene, x)
        return out

    def settings(self):
        return described.sim_settings(self)

    def close(self):
        self.space = self.bodies = self.springs = self.joints = None
        self.shapes = self.walls = None
