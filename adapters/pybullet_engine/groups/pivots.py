"""pybullet's pivoted rigid bodies: scenes holding `RigidBodies` and `RigidPivots` (+ gravity).

Formulation "multibody" (only): per pivot a btMultiBody with a fixed base (mass 0) at the anchor
and one link on a JOINT_SPHERICAL joint at the base's origin. Bullet takes a diagonal inertia, so
the link frame is the body's PRINCIPAL frame (rigid_frames.PrincipalFrames, as the rigid group):
the joint quaternion is q_engine = q_scene (x) q(P), the link's inertial frame sits at the centre
of mass, -P^T body_point in the link frame, with identity orientation and the principal moments
(changeDynamics localInertiaDiagonal). The spherical joint's velocity is the link-frame (body)
angular velocity (measured): world w is rotated into it at build. Stepped by Bullet's
semi-implicit Euler (btMultiBody: joint velocities from the state at k with the gyroscopic term
explicit in the bias force, then the joint quaternion by the new velocity, normalised).

Facts applied (pybullet 3.2.7, docs/engine_notes.md#pybullet; each reported in settings()):
- damping 0 (link linear/angular, joint), maxJointVelocity raised to infinity;
- the spherical joint's default motor acts as friction: setJointMotorControlMultiDof with
  POSITION_CONTROL, gains 0 and force (0, 0, 0);
- measured here: changeDynamics(link 0, localInertiaDiagonal=..., linearDamping=...) in ONE call
  writes the inertia to the BASE (pybullet 3.2.7); the inertia is set in a call of its own and
  the compiled masses and inertias are read back and checked (getDynamicsInfo);
- a collision shape (sphere r = 1e-3 m, filter group/mask 0: never collides), its inertia
  replaced; gravity and fixedTimeStep set, numSubSteps 0.
Observables: x, v (link COM, world), q (scene body frame, (w, x, y, z)), w (world), and the
extras orientation_defect (|q|^2 - 1 of the joint quaternion as Bullet stores it) and pivot_gap
(k,) m (|x + R body_point - anchor|: round-off, the joint is a generalized coordinate).
"""
from __future__ import annotations

import math

import numpy as np

from refsim.engine import ModelGroup, Sim
from refsim.scene import RigidBodies
from refsim.scene.pivots import RigidPivots, check_on_anchor
from refsim.scene.rigid_shapes import RigidShapes

from ..runtime import INTEGRATOR, OwnsClient, c_stdout_silenced, import_pybullet
from .rigid_frames import PrincipalFrames, xyzw_to_matrices

WHO = "pybullet adapter"
COLLISION_RADIUS = 1e-3  # m: a link shape; never collides (filter 0), its inertia replaced
INERTIA_RTOL = 1e-12  # read-back moments vs the scene's: Bullet stores them as given (float64)


def claims(scene) -> bool:
    """Rigid bodies on pivots (with shapes they are the rolling group's)."""
    return scene.part(RigidBodies) is not None and scene.part(RigidPivots) is not None and \
        scene.part(RigidShapes) is None


def supports(engine, scene, integrator):
    if integrator is not None and integrator != "symplectic_euler":
        return f"pybullet's symplectic_euler takes no parameter, got {integrator!r}"
    pivots, rigid = scene.part(RigidPivots), scene.part(RigidBodies)
    try:
        check_on_anchor(pivots, rigid)
    except ValueError as exc:
        return f"{WHO}: {exc}"
    if len(pivots) != len(rigid):
        return (f"{WHO}: every rigid body of a pivoted scene must have a pivot; free bodies "
                f"beside pivoted ones are not modelled by this group")
    return None


def build(engine, scene, dt, integrator, formulation):
    return PybulletPivotSim(import_pybullet(), scene, dt)


MODEL_GROUP = ModelGroup(
    name="pivots", build=build, claims=claims, parts=frozenset({"rigid", "rigid_pivots"}),
    features=frozenset({"rigid", "pivots", "gravity"}), supports=supports,
    integrators=("symplectic_euler",))


class PybulletPivotSim(OwnsClient, Sim):
    def __init__(self, p, scene, dt):
        self.p, self.scene, self.dt, self.steps = p, scene, dt, 0
        self.rigid, self.pivots = scene.part(RigidBodies), scene.part(RigidPivots)
        self.order = self.pivots.body
        self.frames = PrincipalFrames.of(self.rigid.inertia[self.order])
        with c_stdout_silenced():
            self.client = p.connect(p.DIRECT)
        try:
            p.setGravity(*scene.gravity, physicsClientId=self.client)
            p.setPhysicsEngineParameter(fixedTimeStep=dt, numSubSteps=0,
                                        physicsClientId=self.client)
            self.engine_params = p.getPhysicsEngineParameters(physicsClientId=self.client)
            shape = p.createCollisionShape(p.GEOM_SPHERE, radius=COLLISION_RADIUS,
                                           physicsClientId=self.client)
            self.uids = [self._build_pivot(i, shape) for i in range(len(self.order))]
            self._check_dynamics()
        except Exception:
            self.close()
            raise

    def _build_pivot(self, i, shape):
        """Fixed base at the anchor, one spherical link in the principal frame, state set."""
        p, cid, rigid = self.p, self.client, self.rigid
        b = self.order[i]
        com_in_link = -self.frames.axes[i].T @ self.pivots.body_point[i]
        uid = p.createMultiBody(
            baseMass=0.0, baseCollisionShapeIndex=-1, baseVisualShapeIndex=-1,
            basePosition=self.pivots.anchor[i].tolist(), baseOrientation=[0.0, 0.0, 0.0, 1.0],
            linkMasses=[float(rigid.mass[b])], linkCollisionShapeIndices=[shape],
            linkVisualShapeIndices=[-1], linkPositions=[[0.0, 0.0, 0.0]],
            linkOrientations=[[0.0, 0.0, 0.0, 1.0]],
            linkInertialFramePositions=[com_in_link.tolist()],
            linkInertialFrameOrientations=[[0.0, 0.0, 0.0, 1.0]], linkParentIndices=[0],
            linkJointTypes=[p.JOINT_SPHERICAL], linkJointAxis=[[0.0, 0.0, 1.0]],
            physicsClientId=cid)
        p.setCollisionFilterGroupMask(uid, 0, 0, 0, physicsClientId=cid)
        for link in (-1, 0):
            p.changeDynamics(uid, link, linearDamping=0.0, angularDamping=0.0,
                             jointDamping=0.0, maxJointVelocity=math.inf, physicsClientId=cid)
        # alone: with linearDamping & co in the same call it lands on the base (see docstring)
        p.changeDynamics(uid, 0, localInertiaDiagonal=self.frames.moments[i].tolist(),
                         physicsClientId=cid)
        p.setJointMotorControlMultiDof(uid, 0, p.POSITION_CONTROL,
                                       targetPosition=[0.0, 0.0, 0.0, 1.0],
                                       targetVelocity=[0.0, 0.0, 0.0], positionGain=0.0,
                                       velocityGain=0.0, force=[0.0, 0.0, 0.0],
                                       physicsClientId=cid)
        q_engine = self.frames.engine_orientation(rigid.orientation[[b]])
        w_link = xyzw_to_matrices(q_engine)[0].T @ rigid.angular_velocity[b]
        p.resetJointStateMultiDof(uid, 0, targetValue=q_engine[0].tolist(),
                                  targetVelocity=w_link.tolist(), physicsClientId=cid)
        return uid

    def _check_dynamics(self):
        """The link's mass and principal moments are the scene's, the base is fixed (mass 0)."""
        p, cid, rigid = self.p, self.client, self.rigid
        for i, uid in enumerate(self.uids):
            base = p.getDynamicsInfo(uid, -1, physicsClientId=cid)
            link = p.getDynamicsInfo(uid, 0, physicsClientId=cid)
            want = self.frames.moments[i]
            if base[0] != 0.0 or link[0] != rigid.mass[self.order[i]] or \
                    np.abs(np.subtract(link[2], want)).max() > INERTIA_RTOL * want.max():
                raise RuntimeError("pybullet holds other masses/inertias than the scene's")

    def _step_impl(self, n):
        step, cid = self.p.stepSimulation, self.client
        for _ in range(n):
            step(physicsClientId=cid)

    def _observe(self):
        p, cid, n = self.p, self.client, len(self.rigid)
        states = [p.getLinkState(u, 0, computeLinkVelocity=1, computeForwardKinematics=1,
                                 physicsClientId=cid) for u in self.uids]
        joint_q = np.array([p.getJointStateMultiDof(u, 0, physicsClientId=cid)[0]
                            for u in self.uids], float)
        # base and link reference frames are the identity: the link (principal) frame's
        # orientation is the joint quaternion (getLinkState's own is rounded at ~3e-8)
        link_q = joint_q / np.linalg.norm(joint_q, axis=1, keepdims=True)
        out = {"x": np.zeros((n, 3)), "v": np.zeros((n, 3)), "q": np.zeros((n, 4)),
               "w": np.zeros((n, 3)), "orientation_defect": np.zeros(n)}
        out["x"][self.order] = [s[0] for s in states]
        out["v"][self.order] = [s[6] for s in states]
        out["w"][self.order] = [s[7] for s in states]
        out["q"][self.order] = self.frames.scene_orientation(link_q)
        out["orientation_defect"][self.order] = np.sum(joint_q * joint_q, axis=1) - 1.0
        body_point = np.einsum("nij,nj->ni", xyzw_to_matrices(link_q),
                               np.einsum("nji,nj->ni", self.frames.axes,
                                         self.pivots.body_point))
        out["pivot_gap"] = np.linalg.norm(out["x"][self.order] + body_point -
                                          self.pivots.anchor, axis=1)
        return out

    def settings(self):
        prm = self.engine_params
        return {
            "integrator": {**INTEGRATOR, "symplectic": False,
                           "native": "semi-implicit Euler (btMultiBody: joint velocities with "
                                     "the explicit gyroscopic bias, then the joint quaternion)",
                           "symplectic_note": "kick-drift, but the explicit gyroscopic term "
                                              "makes |L| and E drift (not symplectic on "
                                              "rotation)"},
            "dtype": "float64", "threads": 1, "connection": "DIRECT",
            "formulation": "multibody", "fixedTimeStep": prm["fixedTimeStep"],
            "numSubSteps": prm["numSubSteps"],
            "gravity": [prm[f"gravityAcceleration{c}"] for c in "XYZ"],
            "joint": "JOINT_SPHERICAL from a fixed base (mass 0) at the anchor; joint "
                     "quaternion q_scene (x) q(P), joint velocity in the link (principal) frame",
            "motor": "setJointMotorControlMultiDof POSITION_CONTROL, gains 0, force (0, 0, 0) "
                     "(the default motor acts as friction)",
            "linearDamping": 0.0, "angularDamping": 0.0, "jointDamping": 0.0,
            "maxJointVelocity": "inf (the 100 rad/s default clamp removed)",
            "inertia": "principal moments via changeDynamics(localInertiaDiagonal) in a call of "
                       "its own (with damping keywords pybullet 3.2.7 writes it to the base), "
                       "read back and checked; link frame = principal axes (eigh)",
            "principal_moments": self.frames.moments.tolist(),
            "collision_shape": f"sphere r = {COLLISION_RADIUS} m, filter group/mask 0",
            "orientation_update": "joint quaternion by the new joint velocity, normalised",
            "pivots": {"body": self.pivots.body.tolist(),
                       "body_point": self.pivots.body_point.tolist(),
                       "anchor": self.pivots.anchor.tolist()},
        }

