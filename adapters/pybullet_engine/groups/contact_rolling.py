"""pybullet's rolling group: rigid bodies with collision shapes (`RigidShapes`) on walls, with
friction: a disc rolling or slipping on an incline.

Claims every rigid scene with shapes (the pivots and rigid groups leave those out). Each body
is a `btRigidBody` (`useMaximalCoordinates=1`, as the spheres group) with a GEOM_SPHERE of the
shape's radius, for a cylinder too (CYLINDER_NOTE: Bullet's cylinder lifts off and slips);
mass and the scene's diagonal inertia set with changeDynamics (never the shape's). Each wall is
a static GEOM_PLANE through its point. The spheres group's contact settings apply
(adapters/pybullet_engine/contacts.py CONTACT_PARAMS: contactERP = erp = frictionERP = 0, split
impulse off, slop 0, breaking threshold 1e-12 m, 50 iterations to convergence, cone friction),
and its materials: Bullet multiplies the pair's restitution and lateral friction, so every body
and wall gets sqrt(e) = 0 and sqrt(mu); rolling and spinning friction 0; damping 0; sleeping
off.
Step: semi-implicit Euler (velocities with the contact impulses, then positions): kick-drift,
s_k = a h^2 k (k + 1) / 2 on a constant a. Observables: x, v, q (w, x, y, z), w (world),
orientation_defect (|q|^2 - 1 of Bullet's quaternion).
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup, Sim
from refsim.scene import RigidBodies, Walls
from refsim.scene.rigid_shapes import RigidShapes, rolling_scene_refusal

from ..contacts import CONTACT_PARAMS, materials
from ..runtime import INTEGRATOR, OwnsClient, c_stdout_silenced, import_pybullet

WHO = "pybullet adapter"
CYLINDER_NOTE = (
    "a cylinder shape is built as a GEOM_SPHERE of its radius: in planar motion (axis along "
    "world y, checked) both touch the wall at the same point. Measured with GEOM_CYLINDER "
    "(axis turned onto y by the collision frame), dt = 1 ms, 1 s: the disc lifted off by up "
    "to 0.27 mm (slipping: 0.76 mm) and its rolling residual v - w r reached 2.4e-2 m/s; "
    "with the sphere both stay at 1e-15")


def claims(scene) -> bool:
    return scene.part(RigidBodies) is not None and scene.part(RigidShapes) is not None


def supports(engine, scene, integrator):
    if integrator is not None and integrator != "symplectic_euler":
        return f"pybullet's symplectic_euler takes no parameter, got {integrator!r}"
    inertia = scene.part(RigidBodies).inertia
    if np.any(inertia - inertia * np.eye(3)):
        return f"{WHO}: the rolling group takes diagonal body-frame inertia tensors only"
    return rolling_scene_refusal(scene, WHO)


def build(engine, scene, dt, integrator, formulation):
    return PybulletRollingSim(import_pybullet(), scene, dt)


MODEL_GROUP = ModelGroup(
    name="rolling", build=build, claims=claims,
    parts=frozenset({"rigid", "rigid_shapes", "walls"}),
    features=frozenset({"rigid", "shapes", "walls", "contacts", "gravity"}), supports=supports,
    integrators=("symplectic_euler",))


class PybulletRollingSim(OwnsClient, Sim):
    def __init__(self, p, scene, dt):
        self.p, self.scene, self.dt, self.steps = p, scene, dt, 0
        self.rigid, self.shapes = scene.part(RigidBodies), scene.part(RigidShapes)
        walls = scene.part(Walls)
        self.material = materials(scene.contact)
        with c_stdout_silenced():
            self.client = p.connect(p.DIRECT)
        try:
            p.setGravity(*scene.gravity, physicsClientId=self.client)
            p.setPhysicsEngineParameter(fixedTimeStep=dt, numSubSteps=0,
                                        physicsClientId=self.client, **CONTACT_PARAMS)
            self.engine_params = p.getPhysicsEngineParameters(physicsClientId=self.client)
            self.walls = [self._wall(pt, n) for pt, n in zip(walls.point, walls.normal)]
            self.uids = [self._body(i) for i in range(len(self.rigid))]
        except Exception:
            self.close()
            raise

    def _wall(self, point, normal):
        p, cid = self.p, self.client
        shape = p.createCollisionShape(p.GEOM_PLANE, planeNormal=list(normal),
                                       physicsClientId=cid)
        uid = p.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=shape,
                                basePosition=list(point), physicsClientId=cid)
        p.changeDynamics(uid, -1, physicsClientId=cid, **self.material)
        return uid

    def _body(self, i):
        p, cid, rigid, shapes = self.p, self.client, self.rigid, self.shapes
        j = int(np.flatnonzero(shapes.body == i)[0])
        shape = p.createCollisionShape(p.GEOM_SPHERE, radius=float(shapes.radius[j]),
                                       physicsClientId=cid)  # every kind: see CYLINDER_NOTE
        q = rigid.orientation[i]
        uid = p.createMultiBody(baseMass=float(rigid.mass[i]), baseCollisionShapeIndex=shape,
                                baseVisualShapeIndex=-1, basePosition=rigid.position[i].tolist(),
                                baseOrientation=[q[1], q[2], q[3], q[0]],
                                useMaximalCoordinates=1, physicsClientId=cid)
        p.changeDynamics(uid, -1, mass=float(rigid.mass[i]),
                         localInertiaDiagonal=np.diag(rigid.inertia[i]).tolist(),
                         linearDamping=0.0, angularDamping=0.0,
                         activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING,
                         physicsClientId=cid, **self.material)
        p.resetBaseVelocity(uid, rigid.velocity[i].tolist(),
                            rigid.angular_velocity[i].tolist(), physicsClientId=cid)
        return uid

    def _step_impl(self, n):
        step, cid = self.p.stepSimulation, self.client
        for _ in range(n):
            step(physicsClientId=cid)

    def _observe(self):
        p, cid = self.p, self.client
        poses = [p.getBasePositionAndOrientation(u, physicsClientId=cid) for u in self.uids]
        speeds = [p.getBaseVelocity(u, physicsClientId=cid) for u in self.uids]
        q_xyzw = np.array([s[1] for s in poses], float)
        return {"x": np.array([s[0] for s in poses], float),
                "v": np.array([s[0] for s in speeds], float),
                "q": q_xyzw[:, [3, 0, 1, 2]], "w": np.array([s[1] for s in speeds], float),
                "orientation_defect": np.sum(q_xyzw * q_xyzw, axis=1) - 1.0}

    def settings(self):
        prm = self.engine_params
        return {
            "integrator": {**INTEGRATOR, "native": "semi-implicit Euler (btRigidBody: "
                           "velocities with the contact impulses, then positions)"},
            "dtype": "float64", "threads": 1, "connection": "DIRECT",
            "formulation": "btRigidBody (useMaximalCoordinates=1)",
            "fixedTimeStep": prm["fixedTimeStep"], "numSubSteps": prm["numSubSteps"],
            "gravity": [prm[f"gravityAcceleration{c}"] for c in "XYZ"],
            "contact_model": "impulse", "detection": "discrete",
            "contact_params": dict(CONTACT_PARAMS),
            "materials": {**self.material, "mapping": "sqrt(e), sqrt(mu) on every body and "
                          "wall (Bullet multiplies the pair's values)"},
            "linearDamping": 0.0, "angularDamping": 0.0, "sleeping": "disabled",
            "shapes": "GEOM_SPHERE of the shape's radius for every kind; walls GEOM_PLANE "
                      "static bodies", "cylinder_as_sphere": CYLINDER_NOTE,
            "inertia": "scene mass and diagonal inertia via changeDynamics (shape's unused)",
        }

