"""Scenes without contacts: point masses and bodies on rods as Featherstone multibodies.

Every body is its own `btMultiBody`: a free point mass is a floating base; a body on a rod is a
fixed base at the anchor with one revolute link whose centre of mass is the body (generalized
coordinates: the rod length is exact, so the constraint error is zero).

Facts applied, measured on pybullet 3.2.7 (docs/engine_notes.md#pybullet):
- multibodies carry speed-dependent damping 0.04: `linearDamping = angularDamping = 0` on the
  base and the link, `jointDamping = 0` on the joint;
- multibody speed is clamped at 100 m/s (`maxJointVelocity`): raised to infinity, so an
  instability shows instead of being clamped away (the k = 1e6 spring reaches 100 m/s);
- joint velocity motors act as friction: `VELOCITY_CONTROL` with `force = 0`;
- inertia is the scene's (0 for a point mass), set with `changeDynamics(localInertiaDiagonal)`;
  there are no collision shapes, so nothing is recomputed from a shape and nothing collides.
"""
from __future__ import annotations

import math

import numpy as np

from ..common.checks import rods_per_body
from ..common.hinges import rod_start_refusal

MAX_SPEED = math.inf  # replaces pybullet's 100 m/s multibody clamp
WHO = "pybullet adapter"  # how the reasons name this engine


def rods_mismatch(scene):
    """A reason when a body has two rods or a rod a state its hinge cannot hold, else None
    (for a scene holding rods: a `Joints` part)."""
    return (rods_per_body(scene, WHO, why=" (two rods on a body form a closed loop)")
            or rod_start_refusal(scene, WHO))


def build_multibodies(p, cid, particles, joints=(), frames=None):
    """(multibody id, link index) per body of `particles` (the `Particles` part): -1 for a free
    base, 0 for a rod's link; and the indices of the bodies on rods. `joints`: the rods'
    `Joint` records (() for none) with their `frames` (a HingeFrames)."""
    theta, omega, rods = (), (), {}
    if joints:
        theta, omega = frames.initial_angles(particles.position, particles.velocity)
        rods = {int(b): k for k, b in enumerate(frames.bodies)}  # body -> its rod's index
    handles, hinges = [], []
    for i, body in enumerate(particles.to_records()):
        if i in rods:
            k = rods[i]
            handles.append((hinge_body(p, cid, body, joints[k], frames.d[k],
                                       (theta[k], omega[k])), 0))
            hinges.append(i)
        else:
            handles.append((free_body(p, cid, body), -1))
    return handles, hinges


def free_body(p, cid, body):
    """A floating base without collision shape at the body's position and velocity."""
    uid = p.createMultiBody(baseMass=body.mass, baseCollisionShapeIndex=-1,
                            baseVisualShapeIndex=-1, basePosition=body.position,
                            physicsClientId=cid)
    exact_dynamics(p, cid, uid, -1, body.inertia)
    p.resetBaseVelocity(uid, body.velocity, body.angular_velocity, physicsClientId=cid)
    return uid


def hinge_body(p, cid, body, joint, d, start):
    """Fixed base at the anchor, one revolute link; the link's centre of mass (the body) at
    L d for q = 0, d hanging along gravity in the hinge plane (HingeFrames.d). The joint axis
    is -axis, so q turns d towards s = d x axis: q is refsim's hinge angle theta, set to
    `start` = (theta, omega)."""
    uid = p.createMultiBody(
        baseMass=0.0, baseCollisionShapeIndex=-1, baseVisualShapeIndex=-1,
        basePosition=joint.anchor, linkMasses=[body.mass], linkCollisionShapeIndices=[-1],
        linkVisualShapeIndices=[-1], linkPositions=[(0.0, 0.0, 0.0)],
        linkOrientations=[(0.0, 0.0, 0.0, 1.0)],
        linkInertialFramePositions=[tuple(joint.length * d)],
        linkInertialFrameOrientations=[(0.0, 0.0, 0.0, 1.0)], linkParentIndices=[0],
        linkJointTypes=[p.JOINT_REVOLUTE], linkJointAxis=[tuple(-np.asarray(joint.axis))],
        useMaximalCoordinates=0, physicsClientId=cid)
    exact_dynamics(p, cid, uid, -1, None)  # the fixed base: no inertia to set
    exact_dynamics(p, cid, uid, 0, body.inertia)
    p.setJointMotorControl2(uid, 0, p.VELOCITY_CONTROL, force=0.0, physicsClientId=cid)
    theta, omega = start
    p.resetJointState(uid, 0, float(theta), float(omega), physicsClientId=cid)
    return uid


def exact_dynamics(p, cid, uid, link, inertia):
    """docs/engine_notes.md#pybullet (pybullet 3.2.7): damping off, 100 m/s clamp raised,
    inertia as given (None for a fixed base), no sleeping."""
    kw = dict(linearDamping=0.0, angularDamping=0.0, maxJointVelocity=MAX_SPEED,
              activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING, physicsClientId=cid)
    if link >= 0:
        kw["jointDamping"] = 0.0
    if inertia is not None:
        kw["localInertiaDiagonal"] = (inertia,) * 3
    p.changeDynamics(uid, link, **kw)


def multibody_settings(particles, hinges):
    """The settings of the multibody formulation for the `Particles` part (the spheres group
    overrides some of them)."""
    return {
        "formulation": ("generalized coordinates: fixed base at the anchor + revolute link "
                        "per rod (Featherstone)" if hinges else "free multibody base"),
        "useMaximalCoordinates": False,
        "linearDamping": 0.0, "angularDamping": 0.0,
        "maxJointVelocity": "inf (default 100 m/s clamp removed)",
        "inertia": "as given by the scene (0 for a point mass) via localInertiaDiagonal",
        "inertia_values": particles.inertia.tolist(),
        "collision_shapes": "none (nothing collides; no ground plane)",
        "sleeping": "disabled",
    }


def hinge_settings():
    """The settings added when some body is on a rod."""
    return dict(jointDamping=0.0, velocity_motor="off (VELOCITY_CONTROL, force=0)",
                joint_limits="none", joint_angle="q = refsim's hinge angle theta "
                "(joint axis -axis), set with resetJointState")
