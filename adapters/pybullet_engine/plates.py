"""Thin static plates (the Plates part, issue 28 tunnelling) in pybullet's sphere scenes, and the
continuous detection of the "ccd" formulation.

Each plate is a static GEOM_BOX body (half extents (w/2, half_size, half_size) in a frame whose
x axis is the plate's normal) with the walls' materials and collision margin 0. Facts measured
on pybullet 3.2.7 (tests/engines/pybullet/test_pybullet_tunnelling.py):
- a box keeps a collision margin of 1 mm at least: a box thinner than 2 mm collides as 2 mm
  thick (a 0.4 mm plate reported a sphere 1e-6 m away as 0.8 mm deep); `collisionMargin = 0`
  (changeDynamics) makes the distance exact;
- "" (discrete, the spheres group's bodies: maximal-coordinate btRigidBody): a sphere found
  overlapping with its centre past the plate's mid-plane is pushed out through the far face
  (the box test takes the nearer face): it tunnels from v dt > w/2 + r, half the geometric
  (w + 2r) / dt;
- "ccd": `ccdSweptSphereRadius = r` per sphere (Bullet sweeps a sphere of that radius when a
  step moves a body more than its motion threshold, r / 2 as pybullet sets it) and
  `allowedCcdPenetration = 0` (Bullet's default 0.04 m ignores sweep hits that would
  penetrate less than that: a r = 5 mm sphere against a 2 mm plate tunnelled at 0.55 to 3
  times (w + 2r) / dt with it). A swept hit moves the sphere only to the surface, its
  velocity becoming (distance to the surface) / dt: it rebounds at e times that, not at e
  times the impact speed (the impact's energy is lost); slower spheres (under r / 2 per
  step) meet the discrete contact, which bounces them exactly;
- multibody bases (useMaximalCoordinates = 0) ignore ccdSweptSphereRadius and are clamped at
  100 m/s (maxJointVelocity): neither formulation uses them.
"""
from __future__ import annotations

import numpy as np

from .contacts import materials

FORMULATIONS = ("", "ccd")
CCD_PARAMS = {"allowedCcdPenetration": 0.0}  # Bullet's default 0.04 m (reason above)
PLATE_MARGIN = 0.0  # m; pybullet's box margin (1 mm) thickens plates thinner than 2 mm
CCD_NOTE = (
    "ccdSweptSphereRadius = r on every sphere (a swept sphere when a step moves a body more "
    "than r / 2, pybullet's motion threshold), allowedCcdPenetration = 0 (default 0.04 m: "
    "hits that would penetrate less are ignored, so spheres of a few mm tunnelled at 0.55-3 "
    "times (w + 2r) / dt); a swept hit moves the sphere to the surface with velocity "
    "(distance to the surface) / dt and it rebounds at e times that, not e v")
DISCRETE_NOTE = (
    "off (ccdSweptSphereRadius = 0, the default): discrete detection at the previous step's "
    "positions; a sphere whose centre is past a plate's mid-plane is pushed out through the "
    "far face: tunnels from v dt > w/2 + r")
SPEED_CLAMP = (
    "none: every sphere is a maximal-coordinate btRigidBody (the 100 m/s maxJointVelocity "
    "clamp acts on multibody bases, which also ignore ccdSweptSphereRadius)")


def frame_quaternions(normal: np.ndarray) -> np.ndarray:
    """(x, y, z, w) per plate (pybullet's order): the shortest rotation taking the x axis to
    the plate's `normal` (p, 3) unit; a half turn about z for -x. The in-plane axes it leaves
    do not matter for a square plate hit away from its rim."""
    nx = normal[:, 0]
    axis = np.stack([np.zeros_like(nx), -normal[:, 2], normal[:, 1]], axis=1)  # x cross n
    half = np.sqrt(np.maximum(0.5 * (1.0 + nx), 0.0))  # cos(angle / 2)
    sin_half = np.sqrt(np.maximum(0.5 * (1.0 - nx), 0.0))
    norm = np.linalg.norm(axis, axis=1, keepdims=True)
    unit = np.where(norm > 0, axis / np.where(norm > 0, norm, 1.0), [[0.0, 0.0, 1.0]])
    return np.concatenate([unit * sin_half[:, None], half[:, None]], axis=1)


def build_plates(p, cid, plates, contact) -> list:
    """One static GEOM_BOX body per plate of the `plates` part, the `contact` model's
    materials, collision margin 0; the body ids."""
    quats, per_plate, uids = frame_quaternions(plates.normal), materials(contact), []
    rows = zip(plates.center, quats, plates.thickness, plates.half_size)
    for centre, quat, w, half in rows:
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.5 * w, half, half],
                                       physicsClientId=cid)
        uid = p.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=shape,
                                basePosition=centre.tolist(), baseOrientation=quat.tolist(),
                                useMaximalCoordinates=1, physicsClientId=cid)
        p.changeDynamics(uid, -1, collisionMargin=PLATE_MARGIN, physicsClientId=cid,
                         **per_plate)
        uids.append(uid)
    return uids


def enable_ccd(p, cid, handles, radii):
    """The "ccd" formulation: a swept sphere of each body's radius, and Bullet's CCD
    penetration allowance 0."""
    p.setPhysicsEngineParameter(**CCD_PARAMS, physicsClientId=cid)
    for (uid, _), r in zip(handles, radii):
        p.changeDynamics(uid, -1, ccdSweptSphereRadius=float(r), physicsClientId=cid)


def plate_settings(plates, formulation: str) -> dict:
    """The settings a scene with plates adds (or replaces) under `formulation`."""
    ccd = formulation == "ccd"
    return {
        "detection": "continuous" if ccd else "discrete",
        "plate_side": "nearest",
        # the overlap is kept (contact ERP 0): the velocity alone changes at the next step
        "plate_projection": "none",
        "plate_side_note": ("an overlap found at a step's end pushes the sphere out of the face "
                            "of least penetration (through, once its centre is past the "
                            "mid-plane); the overlap is kept (contact ERP 0): the bounce "
                            "starts from the overlapped position"),
        "ccd": CCD_NOTE if ccd else DISCRETE_NOTE,
        "ccd_parameters": ({"ccdSweptSphereRadius": "each sphere's radius", **CCD_PARAMS,
                            "allowedCcdPenetration_default": 0.04} if ccd else {}),
        "plates": (f"{len(plates)} static GEOM_BOX bodies, half extents (w/2, half_size, "
                   f"half_size) in a frame whose x axis is the normal, collisionMargin "
                   f"{PLATE_MARGIN} (pybullet's 1 mm margin thickens a box to 2 mm at least), "
                   f"the walls' materials"),
        "speed_clamp": SPEED_CLAMP,
    }
