"""The pybullet Sim: one DIRECT client per build, the world's parameters, stepping, observing
and the settings that state every parameter changed from pybullet's defaults.

Facts applied, measured on pybullet 3.2.7 (docs/engine_notes.md#pybullet): gravity defaults
to 0 and the step to 1/240 s: both are set; `fixedTimeStep` is the whole step, `numSubSteps=0`
(with sub-steps an explicit spring is unstable at any dt). Stepping is one `stepSimulation` Python
call per step (plus the force calls of forces.py, if any).
"""
from __future__ import annotations

import numpy as np

from refsim.engine import Sim

from .contacts import CONTACT_PARAMS, build_spheres, build_walls, contact_settings
from .forces import ForceTerms
from .multibodies import build_multibodies, hinge_settings, multibody_settings
from .runtime import INTEGRATOR, OwnsClient, body_state, c_stdout_silenced


class PybulletSim(OwnsClient, Sim):
    def __init__(self, p, scene, dt):
        self.p, self.scene, self.dt, self.steps = p, scene, dt, 0
        with c_stdout_silenced():
            self.client = p.connect(p.DIRECT)
        self.contact = scene.contact
        self.walls_built = "none"
        try:
            self.engine_params = self._configure_world()
            if self.contact is not None:
                self.handles, self.hinges = build_spheres(p, self.client, scene), []
                self.walls_built = build_walls(p, self.client, scene)
            else:
                self.handles, self.hinges = build_multibodies(p, self.client, scene)
            self.forces = ForceTerms(scene)
            self._apply = self.forces.applier(p, self.client, self.handles)
        except Exception:
            self.close()
            raise

    def _configure_world(self):
        """Gravity, the step, the contact parameters; the effective values, read back."""
        p, cid = self.p, self.client
        p.setGravity(*self.scene.gravity, physicsClientId=cid)
        p.setPhysicsEngineParameter(fixedTimeStep=self.dt, numSubSteps=0, physicsClientId=cid)
        if self.contact is not None:
            p.setPhysicsEngineParameter(**CONTACT_PARAMS, physicsClientId=cid)
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
        out = {"x": np.array([s[0] for s in states], float),
               "v": np.array([s[1] for s in states], float)}
        if self.scene.joints:
            out["constraint"] = np.zeros(len(self.scene.joints))  # generalized coordinates
        if self.contact is not None:
            out["w"] = np.array([self.p.getBaseVelocity(uid, physicsClientId=self.client)[1]
                                 for uid, _ in self.handles], float)
        return out

    def settings(self):
        out = {**self._world_settings(), **multibody_settings(self.scene, self.hinges),
               "stages": self._stages(), **self.forces.describe(self.handles)}
        if self.contact is not None:
            out.update(contact_settings(self.scene, self.walls_built))
        if self.hinges:
            out.update(hinge_settings())
        return out

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
        stages += self.forces.names() + (["revolute_generalized"] if self.hinges else [])
        if self.contact is not None:
            stages += ["contacts:discrete_detection", "contacts:impulses"]
        return stages + ["integrate:symplectic_euler"]

