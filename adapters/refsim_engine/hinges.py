"""HingeSim: rods in generalized coordinates, one angle per rod about its hinge axis."""
from __future__ import annotations

import numpy as np

from refsim.models.joints import HingeSystem
from refsim.scene import Particles

from ..common.hinges import HingeFrames
from .stepped import SteppedSim


class HingeSim(SteppedSim):
    def __init__(self, scene, dt, stepper):
        self.scene, self.bodies = scene, scene.part(Particles)
        bodies = self.bodies
        self.frames = frames = HingeFrames.from_scene(scene)
        theta0, omega0 = frames.initial_angles(bodies.position, bodies.velocity)
        g_over_l = frames.g_plane / frames.length
        drag_over_m = scene.linear_drag / bodies.mass[frames.bodies]
        self.scalar = len(frames.bodies) == 1
        if self.scalar:  # one rod: plain-float state, no numpy overhead per operation
            theta0, omega0, g_over_l, drag_over_m = (float(a[0]) for a in
                                                     (theta0, omega0, g_over_l, drag_over_m))
        system = HingeSystem(g_over_l=g_over_l, drag_over_m=drag_over_m,
                             velocity_dependent=scene.linear_drag > 0)
        super().__init__(dt, stepper, system, theta0, omega0)

    def stages(self):
        stages = ["gravity"] if np.any(self.system.g_over_l) else []
        if self.system.velocity_dependent:
            stages.append("drag")
        return stages + ["hinge_generalized", f"integrate:{self.stepper.name}"]

    def _observe(self):
        theta, omega = (np.atleast_1d(c) for c in self.coordinates())
        x, v = self.frames.cartesian(theta, omega, self.bodies.position,
                                      self.bodies.velocity)
        return {"x": x, "v": v, "constraint": np.zeros(len(self.frames.bodies))}

    def settings(self):
        return {**self.base_settings(), "formulation": "generalized coordinate (hinge angle)"}
