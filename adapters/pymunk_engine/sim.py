"""PymunkSim: one pymunk Space stepped with space.step(dt) and observed in refsim's axes."""
from __future__ import annotations

import numpy as np

from refsim.engine import Sim

from ..common.hinges import rod_length_errors
from . import settings as described
from .plane import Plane
from .space import add_joint, add_spring, make_body, make_circles, make_space, make_wall


class PymunkSim(Sim):
    def __init__(self, pymunk, scene, dt, variant):
        self.scene, self.dt, self.variant = scene, dt, variant
        self.plane = plane = Plane(scene.dim)
        self.space = space = make_space(pymunk, scene, variant, plane.to2d(scene.gravity))
        self.bodies = [make_body(pymunk, b, plane) for b in scene.bodies]
        self.shapes = (make_circles(pymunk, self.bodies, scene) if scene.contact is not None
                       else [])
        self.walls = [make_wall(pymunk, space, w, scene, plane) for w in scene.walls]
        space.add(*self.bodies, *self.shapes, *self.walls)  # one batched add
        self.springs = [add_spring(pymunk, space, self.bodies, s, plane) for s in scene.springs]
        self.joints = [add_joint(pymunk, space, self.bodies, j, plane, variant)
                       for j in scene.joints]
        # drag as the force -b v set before each step (see `_step_impl`), unless pymunk's
        # global damping carries it (variant space_damping)
        self.drag = scene.linear_drag if variant != "space_damping" else 0.0

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
        if self.scene.contact is not None:  # rotation: spheres in contact can spin
            w = np.zeros((nb, 3))
            w[:, self.plane.normal_axis] = [self.plane.spin_sign * b.angular_velocity
                                            for b in self.bodies]
            out["w"] = w
        if self.scene.joints:
            out["constraint"] = rod_length_errors(self.scene, x)
        return out

    def settings(self):
        return described.sim_settings(self)

    def close(self):
        self.space = self.bodies = self.springs = self.joints = None
        self.shapes = self.walls = None
