"""HingeSim: rods in generalized coordinates, one angle per rod about its hinge axis."""
from __future__ import annotations

import numpy as np

from refsim.models.joints import (HingeSystem, cartesian_to_hinge, hinge_frame,
                                  hinge_to_cartesian)

from .stepped import SteppedSim


class HingeSim(SteppedSim):
    def __init__(self, scene, dt, stepper):
        self.scene = scene
        frames = [hinge_frame(j.axis, scene.gravity) for j in scene.joints]
        self.d = np.array([f[0] for f in frames])  # in-plane gravity: theta = 0
        self.s = np.array([f[1] for f in frames])  # d x axis: theta grows towards s
        g_plane = np.array([f[2] for f in frames])
        self.bodies = np.array([j.body for j in scene.joints])
        self.anchor = np.array([j.anchor for j in scene.joints])
        self.length = np.array([j.length for j in scene.joints])
        theta0, omega0 = self._initial_angles()
        g_over_l = g_plane / self.length
        drag_over_m = scene.linear_drag / scene.masses[self.bodies]
        self.scalar = len(self.bodies) == 1
        if self.scalar:  # one rod: plain-float state, no numpy overhead per operation
            theta0, omega0, g_over_l, drag_over_m = (float(a[0]) for a in
                                                     (theta0, omega0, g_over_l, drag_over_m))
        system = HingeSystem(g_over_l=g_over_l, drag_over_m=drag_over_m,
                             velocity_dependent=scene.linear_drag > 0)
        super().__init__(dt, stepper, system, theta0, omega0)

    def _initial_angles(self):
        """(theta, omega) per rod from the scene's Cartesian start (build time only)."""
        x0 = self.scene.positions[self.bodies]
        v0 = self.scene.velocities[self.bodies]
        pairs = [cartesian_to_hinge(x0[i], v0[i], self.anchor[i], self.length[i], self.d[i],
                                    self.s[i]) for i in range(len(self.bodies))]
        return np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])

    def stages(self):
        stages = ["gravity"] if np.any(self.system.g_over_l) else []
        if self.system.velocity_dependent:
            stages.append("drag")
        return stages + ["hinge_generalized", f"integrate:{self.stepper.name}"]

    def _observe(self):
        theta, omega = (np.atleast_1d(c) for c in self.coordinates())
        xb, vb = hinge_to_cartesian(theta, omega, self.anchor, self.length, self.d, self.s)
        x, v = self.scene.positions.copy(), self.scene.velocities.copy()
        x[self.bodies], v[self.bodies] = xb, vb
        return {"x": x, "v": v, "constraint": np.zeros(len(self.bodies))}

    def settings(self):
        return {**self.base_settings(), "formulation": "generalized coordinate (hinge angle)"}
