"""pybullet's n-body gravity: scenes whose parts are exactly `Particles` + `GravityPairs`.

Bullet has no pair forces between bodies: before every `stepSimulation` the adapter reads each
body's position (`getBasePositionAndOrientation`, one call per body), computes the all-pairs
Newtonian force in numpy (refsim/models/nbody_gravity.py `pair_accelerations`, softening
included) and applies m a(x_k) with `applyExternalForce` at the centre of mass in WORLD_FRAME
(one call per body); Bullet clears external forces after every step. That is 2 n + 1 Python
calls per step: this engine's real cost in this use, kept in the timing.

Bodies: the engine's own free point mass (multibodies.free_body: a floating multibody base
without collision shape, so nothing collides; linear/angular damping 0, replacing the hidden
0.04; the 100 m/s speed clamp raised; the scene's inertia; sleeping off). World: gravity the
scene's, `fixedTimeStep = dt`, `numSubSteps = 0` (read back and reported).
Step: Bullet's semi-implicit Euler, v += h a(x_k), then x += h v: refsim's symplectic_euler
(kick-drift). Measured (pybullet 3.2.7): bit for bit with refsim's symplectic_euler when the
masses are powers of two (Bullet's f / m then returns a exactly), to round-off otherwise.
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup, Sim
from refsim.models.nbody_gravity import pair_accelerations
from refsim.scene import Particles
from refsim.scene.gravity_pairs import GravityPairs

from ..multibodies import free_body, multibody_settings
from ..runtime import INTEGRATOR, OwnsClient, c_stdout_silenced, import_pybullet

COST_NOTE = ("pair force computed in numpy and applied through applyExternalForce with one "
             "Python call per step (per body for the position read and the force, plus "
             "stepSimulation: 2 n + 1 calls): that is this engine's real cost in this use")


def claims(scene) -> bool:
    return scene.part_kinds() == {"particles", "gravity_pairs"}


def supports(engine, scene, integrator):
    if integrator is not None and integrator != "symplectic_euler":
        return f"pybullet's symplectic_euler takes no parameter, got {integrator!r}"
    return None


def build(engine, scene, dt, integrator, formulation):
    return PybulletGravitySim(import_pybullet(), scene, dt)


MODEL_GROUP = ModelGroup(
    name="gravity_pairs", build=build, claims=claims,
    parts=frozenset({"particles", "gravity_pairs"}),
    features=frozenset({"gravity_pairs", "gravity"}), supports=supports,
    integrators=("symplectic_euler",))


class PybulletGravitySim(OwnsClient, Sim):
    """One DIRECT client; one free multibody base per particle."""

    def __init__(self, p, scene, dt):
        self.p, self.scene, self.dt, self.steps = p, scene, dt, 0
        part, self.particles = scene.part(GravityPairs), scene.part(Particles)
        self.G, self.softening = part.G, part.softening
        self.masses = np.array(self.particles.mass)
        with c_stdout_silenced():
            self.client = p.connect(p.DIRECT)
        try:
            p.setGravity(*scene.gravity, physicsClientId=self.client)
            p.setPhysicsEngineParameter(fixedTimeStep=dt, numSubSteps=0,
                                        physicsClientId=self.client)
            self.engine_params = p.getPhysicsEngineParameters(physicsClientId=self.client)
            self.uids = [free_body(p, self.client, b)  # build time
                         for b in self.particles.to_records()]
            self._check_masses()
        except Exception:
            self.close()
            raise

    def _check_masses(self):
        p, cid = self.p, self.client
        held = [p.getDynamicsInfo(u, -1, physicsClientId=cid)[0] for u in self.uids]
        if not np.array_equal(held, self.masses):
            raise RuntimeError("pybullet holds other masses than the scene's")

    def _positions(self) -> np.ndarray:
        get, cid = self.p.getBasePositionAndOrientation, self.client
        return np.array([get(u, physicsClientId=cid)[0] for u in self.uids], float)

    def _step_impl(self, n):
        p, cid, uids, m = self.p, self.client, self.uids, self.masses
        apply, step, world = p.applyExternalForce, p.stepSimulation, p.WORLD_FRAME
        for _ in range(n):  # pybullet has no pair forces: a Python round trip per step
            x = self._positions()
            forces = m[:, None] * pair_accelerations(x, m, self.G, self.softening)
            for uid, f, xi in zip(uids, forces.tolist(), x.tolist()):  # one call per body
                apply(uid, -1, f, xi, world, physicsClientId=cid)
            step(physicsClientId=cid)

    def _observe(self):
        get_v, cid = self.p.getBaseVelocity, self.client
        v = np.array([get_v(u, physicsClientId=cid)[0] for u in self.uids], float)
        return {"x": self._positions(), "v": v}

    def settings(self):
        prm = self.engine_params
        return {
            "integrator": dict(INTEGRATOR, force_frozen_over_step=True),
            "dtype": "float64", "threads": 1, "connection": "DIRECT",
            "fixedTimeStep": prm["fixedTimeStep"], "numSubSteps": prm["numSubSteps"],
            "gravity": [prm[f"gravityAcceleration{c}"] for c in "XYZ"],
            **multibody_settings(self.particles, []),
            "external_force_method": (
                "applyExternalForce(link -1, m a(x_k), at the base position, WORLD_FRAME) "
                "before every stepSimulation, from the positions at the step's start (cleared "
                "after every step): kick-drift, refsim's symplectic_euler"),
            "python_calls_per_step": 2 * len(self.uids) + 1,
            "python_per_step": COST_NOTE,
            "pair_force": {"G": self.G, "softening": self.softening, "pairs": "all",
                           "kernel": "refsim.models.nbody_gravity.pair_accelerations (numpy)"},
        }

