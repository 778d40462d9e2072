"""The Sim the particles and spheres groups share: one DIRECT client per build, the world's
parameters, stepping with the external forces, observing and the settings that state every
parameter changed from pybullet's defaults. A group's subclass builds the bodies
(`_build_bodies`) and adds its own observables, stages and settings.

Facts applied, measured on pybullet 3.2.7 (docs/engine_notes.md#pybullet): gravity defaults
to 0 and the step to 1/240 s: both are set; `fixedTimeStep` is the whole step, `numSubSteps=0`
(with sub-steps an explicit spring is unstable at any dt). Stepping is one `stepSimulation` Python
call per step (plus the force calls of forces.py, if any).
"""
from __future__ import annotations

import numpy as np

from refsim.engine import Sim

from .multibodies import multibody_settings
from .runtime import INTEGRATOR, OwnsClient, body_state, c_stdout_silenced


class PybulletSim(OwnsClient, Sim):
    """The bodies of `particles` (the scene's `Particles` part) under the scene's gravity and
    the external `forces` (forces.ForceTerms). Subclasses set `world_params` (further
    setPhysicsEngineParameter values), `model_stages` and `_build_bodies`."""

    world_params: dict = {}  # setPhysicsEngineParameter values beyond the step (a contact model's)
    model_stages: tuple = ()  # the model's stages between the forces and the integration

    def __init__(self, p, scene, dt, particles, forces):
        self.p, self.scene, self.dt, self.steps = p, scene, dt, 0
        self.particles, self.forces, self.hinges = particles, forces, []
        with c_stdout_silenced():
            self.client = p.connect(p.DIRECT)
        try:
            self.engine_params = self._configure_world()
            self.handles = self._build_bodies()
            self._apply = forces.applier(p, self.client, self.handles)
        except Exception:
            self.close()
            raise

    def _build_bodies(self) -> list:
        """(body id, link index) per body of `self.particles`."""
        raise NotImplementedError

    def _configure_world(self):
        """Gravity, the step, the model's parameters; the effective values, read back."""
        p, cid = self.p, self.client
        p.setGravity(*self.scene.gravity, physicsClientId=cid)
        p.setPhysicsEngineParameter(fixedTimeStep=self.dt, numSubSteps=0, physicsClientId=cid)
        if self.world_params:
            p.setPhysicsEngineParameter(**self.world_params, physicsClientId=cid)
        return p.getPhysicsEngineParameters(physicsClientId=cid)

    # -- contract ------------------------------------------------------------------------------
    def _step_impl(self, n):
        step, cid, apply = self.p.stepSimulation, self.client, self._apply
        if apply is None:
            for _ in range(n):
                step(physicsClientId=cid)
        else:
            for _ in range(n):
                apply()
                step(physicsClientId=cid)

    def _observe(self):
        states = [body_state(self.p, self.client, uid, link) for uid, link in self.handles]
        return {"x": np.array([s[0] for s in states], float),
                "v": np.array([s[1] for s in states], float)}

    def settings(self):
        return {**self._world_settings(), **multibody_settings(self.particles, self.hinges),
                "stages": self._stages(), **self.forces.describe(self.handles)}

    def _world_settings(self):
        prm = self.engine_params
        return {
            "integrator": dict(INTEGRATOR), "dtype": "float64", "threads": 1,
            "dtype_note": ("pybullet wheels are double precision: free fall and springs agree "
                           "with refsim's float64 kick-drift bit for bit"),
            "connection": "DIRECT", "fixedTimeStep": prm["fixedTimeStep"],
            "numSubSteps": prm["numSubSteps"],
            "gravity": [prm[f"gravityAcceleration{c}"] for c in "XYZ"],
        }

    def _stages(self):
        stages = ["gravity"] if any(self.scene.gravity) else []
        return stages + self.forces.names() + list(self.model_stages) + \
            ["integrate:symplectic_euler"]
