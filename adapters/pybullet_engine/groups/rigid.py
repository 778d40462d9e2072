"""pybullet's rigid-body group: free bodies with a full inertia tensor (the `rigid` part).

Two formulations, both stepped by Bullet's semi-implicit Euler (velocities
from the state at k, then positions and orientations with the new velocities):
- "multibody" (default): each body a floating `btMultiBody` base. The gyroscopic term
  w x I w is EXPLICIT (Featherstone bias force, btMultiBody m_useGyroTerm): world
  w_{k+1} = w_k - h I_w(q_k)^-1 (w_k x I_w(q_k) w_k), the model's symplectic Euler; measured
  equal to it (quat_exp) to 1e-11 over 1000 steps. |L| then GROWS exactly by
  |L_{k+1}|^2 = |L_k|^2 + h^2 |w_k x L_k|^2.
- "maximal" (`useMaximalCoordinates=1`): each body a `btRigidBody`. Bullet's default flag
  BT_ENABLE_GYROSCOPIC_FORCE_IMPLICIT_BODY (btRigidBody's constructor; pybullet exposes no way
  to change it) replaces the gyroscopic term by ONE Newton step of implicit Euler on the
  body-frame Euler equation I0 (w' - w) + h w' x I0 w' = 0 from w' = w; measured equal to a
  numpy replica to 1e-11: it damps |L| and the energy.
Orientation (both): exponential map q_{k+1} = exp(h w_{k+1} / 2) (x) q_k, normalised every step
(the defect |q|^2 - 1 stays at round-off), with Bullet's ANGULAR_MOTION_THRESHOLD: when
|w| h > pi/4 the rotation per step is 2 atan(tan(pi/8) |w| h / (pi/4)) instead of |w| h (fixed
in C++, reported in settings, not removable from pybullet).

Facts applied (pybullet 3.2.7, docs/engine_notes.md#pybullet): damping 0 (linear, angular);
the multibody base clamps each component of v and w at maxJointVelocity = 100 (measured:
150 rad/s became 100): raised to infinity; sleeping disabled; gravity and fixedTimeStep set,
numSubSteps 0. A collision shape is needed (a maximal body without one is not simulated as a
rigid body): a sphere of radius COLLISION_RADIUS with collisions filtered off (group and mask
0); mass and inertia set explicitly afterwards (the sphere's own inertia is never used). Bullet
takes a diagonal inertia: the body frame is rotated to the principal axes (rigid_frames.py) and
observations are converted back to the scene's body frame.
Observables: x, v, q (scene body frame, (w, x, y, z)), w (world), and per body the extras
orientation_defect (|q|^2 - 1 of Bullet's quaternion, before any normalisation here), energy
(1/2 m v^2 + 1/2 w . I_w w - m g . x, from the observed state) and angular_momentum (world
I_w w about the centre of mass).
"""
from __future__ import annotations

import math

import numpy as np

from refsim.engine import ModelGroup, Sim
from refsim.scene import RigidBodies
from refsim.scene.pivots import RigidPivots
from refsim.scene.rigid_shapes import RigidShapes

from ..runtime import INTEGRATOR, OwnsClient, c_stdout_silenced, import_pybullet
from .rigid_frames import PrincipalFrames, rigid_energy, world_inertia, xyzw_to_matrices

FORMULATIONS = ("multibody", "maximal")
COLLISION_RADIUS = 1e-3  # m: the shape createMultiBody needs; never collides (filter 0)
MAX_COORDINATE_VELOCITY = math.inf  # replaces the multibody base's 100 m/s, 100 rad/s clamp
ANGULAR_MOTION_THRESHOLD = 0.25 * math.pi  # Bullet's per-step rotation limit on |w| h
GYROSCOPIC = {
    "multibody": "explicit w x I w in the Featherstone bias force (btMultiBody gyro term): "
                 "the model's symplectic Euler; |L| grows by h^2 |w x L|^2 per step",
    "maximal": "BT_ENABLE_GYROSCOPIC_FORCE_IMPLICIT_BODY (Bullet's default, not settable "
               "from pybullet): one Newton step of implicit Euler on I0 w' + w x I0 w = 0 "
               "in the body frame; damps |L| and energy",
}

SYMPLECTIC_NOTE = ("kick-drift, but not symplectic on rotation: |L| and E change every step "
                   "by a signed amount (explicit gyroscopic: grow; implicit: shrink), a "
                   "secular drift, not a bounded oscillation")


def claims(scene) -> bool:
    """Scenes holding free rigid bodies: no pivots (the pivots group's) and no shapes (the
    rolling group's); other parts with them are refused by the parts check."""
    return scene.part(RigidBodies) is not None and scene.part(RigidPivots) is None and \
        scene.part(RigidShapes) is None


def supports(engine, scene, integrator):
    if integrator is not None and integrator != "symplectic_euler":
        return f"pybullet's symplectic_euler takes no parameter, got {integrator!r}"
    return None


def formulations(engine, scene):
    return FORMULATIONS


def build(engine, scene, dt, integrator, formulation):
    return PybulletRigidSim(import_pybullet(), scene, dt, formulation or FORMULATIONS[0])


MODEL_GROUP = ModelGroup(
    name="rigid", build=build, claims=claims, parts=frozenset({"rigid"}),
    features=frozenset({"rigid", "gravity"}), supports=supports, formulations=formulations,
    integrators=("symplectic_euler",))


class PybulletRigidSim(OwnsClient, Sim):
    def __init__(self, p, scene, dt, formulation):
        if formulation not in FORMULATIONS:
            raise ValueError(f"pybullet rigid formulation must be one of {list(FORMULATIONS)}, "
                             f"got {formulation!r}")
        self.p, self.scene, self.dt, self.formulation, self.steps = p, scene, dt, formulation, 0
        self.rigid = scene.part(RigidBodies)
        self.frames = PrincipalFrames.of(self.rigid.inertia)
        with c_stdout_silenced():
            self.client = p.connect(p.DIRECT)
        try:
            p.setGravity(*scene.gravity, physicsClientId=self.client)
            p.setPhysicsEngineParameter(fixedTimeStep=dt, numSubSteps=0,
                                        physicsClientId=self.client)
            self.engine_params = p.getPhysicsEngineParameters(physicsClientId=self.client)
            self.uids = self._build_bodies()
        except Exception:
            self.close()
            raise

    def _build_bodies(self) -> list:
        p, cid, rigid = self.p, self.client, self.rigid
        shape = p.createCollisionShape(p.GEOM_SPHERE, radius=COLLISION_RADIUS,
                                       physicsClientId=cid)
        q_engine = self.frames.engine_orientation(rigid.orientation)
        maximal = int(self.formulation == "maximal")
        uids = []
        for i in range(len(rigid)):  # build time: one pybullet body per scene body
            uid = p.createMultiBody(
                baseMass=float(rigid.mass[i]), baseCollisionShapeIndex=shape,
                baseVisualShapeIndex=-1, basePosition=rigid.position[i].tolist(),
                baseOrientation=q_engine[i].tolist(), useMaximalCoordinates=maximal,
                physicsClientId=cid)
            p.setCollisionFilterGroupMask(uid, -1, 0, 0, physicsClientId=cid)
            p.changeDynamics(uid, -1, mass=float(rigid.mass[i]),
                             localInertiaDiagonal=self.frames.moments[i].tolist(),
                             linearDamping=0.0, angularDamping=0.0,
                             maxJointVelocity=MAX_COORDINATE_VELOCITY,
                             activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING,
                             physicsClientId=cid)
            p.resetBaseVelocity(uid, rigid.velocity[i].tolist(),
                                rigid.angular_velocity[i].tolist(), physicsClientId=cid)
            uids.append(uid)
        return uids

    # -- contract ------------------------------------------------------------------------------
    def _step_impl(self, n):
        step, cid = self.p.stepSimulation, self.client
        for _ in range(n):
            step(physicsClientId=cid)

    def _read_state(self):
        """Raw engine state: x, q (x, y, z, w, Bullet's values), v, w, each (n, .)."""
        p, cid = self.p, self.client
        poses = [p.getBasePositionAndOrientation(u, physicsClientId=cid) for u in self.uids]
        speeds = [p.getBaseVelocity(u, physicsClientId=cid) for u in self.uids]
        x = np.array([s[0] for s in poses], float)
        q = np.array([s[1] for s in poses], float)
        v = np.array([s[0] for s in speeds], float)
        w = np.array([s[1] for s in speeds], float)
        return x, q, v, w

    def _observe(self):
        x, q_engine, v, w = self._read_state()
        defect = np.sum(q_engine * q_engine, axis=1) - 1.0
        q_scene = self.frames.scene_orientation(q_engine)
        inertia_w = world_inertia(xyzw_to_matrices(q_engine),
                                  self.frames.moments[:, :, None] * np.eye(3))
        return {"x": x, "v": v, "q": q_scene, "w": w, "orientation_defect": defect,
                "energy": rigid_energy(self.rigid.mass, inertia_w, x, v, w,
                                       self.scene.gravity),
                "angular_momentum": np.einsum("nij,nj->ni", inertia_w, w)}

    def settings(self):
        prm = self.engine_params
        native = ("semi-implicit Euler (btMultiBody base: velocities, then positions)"
                  if self.formulation == "multibody" else
                  "semi-implicit Euler (btRigidBody in btMultiBodyDynamicsWorld: velocities "
                  "with the implicit gyroscopic impulse, then positions)")
        w_h = float(np.max(np.linalg.norm(self.rigid.angular_velocity, axis=1))) * self.dt
        return {
            "integrator": {**INTEGRATOR, "native": native, "symplectic": False,
                           "symplectic_note": SYMPLECTIC_NOTE}, "dtype": "float64",
            "threads": 1, "connection": "DIRECT", "formulation": self.formulation,
            "useMaximalCoordinates": self.formulation == "maximal",
            "fixedTimeStep": prm["fixedTimeStep"], "numSubSteps": prm["numSubSteps"],
            "gravity": [prm[f"gravityAcceleration{c}"] for c in "XYZ"],
            "linearDamping": 0.0, "angularDamping": 0.0,
            "maxJointVelocity": ("inf (the multibody base's 100 m/s, 100 rad/s per-component "
                                 "clamp removed)" if self.formulation == "multibody" else
                                 "not applicable (btRigidBody: no clamp measured, |w| h = 4 "
                                 "kept)"),
            "gyroscopic": GYROSCOPIC[self.formulation],
            "orientation_update": "exponential map exp(h w/2) (x) q, normalised each step",
            "orientation_step_limit": {
                "threshold_w_h": ANGULAR_MOTION_THRESHOLD,
                "rule": "|w| h > pi/4: rotation 2 atan(tan(pi/8) |w| h / (pi/4)) per step",
                "initial_max_w_h": w_h, "exceeded_at_start": w_h > ANGULAR_MOTION_THRESHOLD},
            "inertia": "principal moments via changeDynamics(localInertiaDiagonal); body "
                       "frame rotated to the principal axes (eigh), observed back in the "
                       "scene's body frame",
            "principal_moments": self.frames.moments.tolist(),
            "collision_shape": f"sphere r = {COLLISION_RADIUS} m, collision filter group/mask "
                               "0 (never collides); its inertia replaced",
            "sleeping": "disabled",
            "stages": (["gravity"] if any(self.scene.gravity) else [])
            + ["gyroscopic:" + ("explicit" if self.formulation == "multibody" else
                                "implicit_body_one_newton_step"),
               "integrate:symplectic_euler", "orientation:exp_map_normalised"],
        }

