"""Contact scenes (features "contacts" and "walls", the spheres group): free spheres and static
walls, and the contact parameters the rolling group shares.

Each sphere is a free `btRigidBody` (`createMultiBody(useMaximalCoordinates=1)`, batch-created
with `batchPositions`) with a GEOM_SPHERE shape; a wall is a static body: a box slab per face
when the walls are the six faces of an axis-aligned box holding every body (an infinite
GEOM_PLANE's AABB overlaps every sphere in the broad phase: 2.2x slower at N = 1000), else a
GEOM_PLANE. Bullet's sequential-impulse solver then applies, at the start of every step,
Newton's restitution law (target normal separation e times the approach speed) with Coulomb
friction at every contact found at the positions reached by the previous step: discrete
detection, an impulse model. Facts, measured on pybullet 3.2.7 with the sphere_pairs,
newtons_cradle and sphere_box cases
(each default below breaks the exact outcome; the adapter changes it and says so in settings()):
- restitution and lateral friction are multiplied over the pair (default restitution 0): every
  sphere and wall gets sqrt(e) and sqrt(mu); rolling and spinning friction 0;
- `contactSlop` (default 1e-5 m) is added to the contact distance, so a contact found exactly at
  touching counts as a gap: the approach speed loses 1e-5 / dt (head-on e = 1 came out -0.995,
  not -1, at dt = 1e-3): 0;
- `contactBreakingThreshold` (default 0.02 m, a process-wide global in Bullet) makes contacts
  with a wall before touching; the solver then spends the bounce on closing the gap (e = 1
  against a wall came out 0.0): 1e-12 m, so a wall contact exists only once the shapes touch
  (the bounce is then short by at most 1e-12 / dt m/s). Not 0: at 0, Bullet's sphere-box test
  dropped its fresh contact point on round-off and found the contact only after 0.03-0.1 m
  of penetration (sphere-plane and sphere-sphere contacts were exact at 0 too);
- `restitutionVelocityThreshold` (default 0.2 m/s): slower impacts are perfectly inelastic: 0;
- contact ERP (default: push-out velocity, an e = 0.5 impact came out 10 % fast;
  docs/engine_notes.md#pybullet-contact-erp-push-out 3-12 %):
  `contactERP = erp = frictionERP = 0`, split impulse off, so overlaps are never pushed out and
  velocities change only by the impacts;
- `solverResidualThreshold` (default: the solver stops early) 0, 50 iterations: simultaneous
  contacts (the cradle) are solved to convergence; a lone contact is exact after one;
- `changeDynamics(localInertiaDiagonal=...)` on a maximal-coordinate body without `mass` sets the
  mass to 0 (the step then gives NaN): mass and inertia are set together, the scene's inertia;
- damping set to 0, sleeping disabled; CCD off (the default; at these speeds a body moves a
  hundredth of its radius per step).
A lone impact is then the exact impulse law with the normal of the overlapped pose: head-on
outcomes are exact to round-off at any dt, an oblique one is tilted by the overlap (O(dt)).
"""
from __future__ import annotations

import numpy as np

from ..common.contacts import per_shape_coefficients
from .runtime import INTEGRATOR

# Contact scenes: setPhysicsEngineParameter values (pybullet 3.2.7; reasons in the docstring).
# contactBreakingThreshold is Bullet's global gContactBreakingThreshold: it holds for every
# client in the process, so every contact build sets it (nothing else in refsim changes it).
CONTACT_PARAMS = {
    "contactERP": 0.0, "erp": 0.0, "frictionERP": 0.0, "useSplitImpulse": 0,
    "contactSlop": 0.0, "contactBreakingThreshold": 1e-12, "restitutionVelocityThreshold": 0.0,
    "numSolverIterations": 50, "solverResidualThreshold": 0.0, "enableConeFriction": 1,
    "deterministicOverlappingPairs": 1,
}
WHO = "pybullet adapter"  # how the reasons name this engine
SLAB_MIN_THICKNESS = 1.0  # m; a wall slab is at least this thick (and at least the box size)
# pybullet's defaults that CONTACT_PARAMS replaces, with what each did (measured, dt = 1e-3)
CONTACT_DEFAULTS = {
    "contactSlop": "1e-5 m: head-on e=1 gave -0.995 (approach speed short by 1e-5/dt)",
    "contactBreakingThreshold": ("0.02 m (process-global): a contact before touching absorbs "
                                 "the bounce (e=1 on a wall gave 0.0); 0 breaks sphere-box "
                                 "contacts (found 0.03-0.1 m deep): 1e-12 m"),
    "restitutionVelocityThreshold": "0.2 m/s: head-on at 2 x 0.05 m/s gave e=0",
    "contactERP": ("default push-out: head-on e=0.5 with overlap off by 0.049 m/s (+10 %); "
                   "contactERP 0.2 / 0.8 gave +24 % / +98 %"),
    "solverResidualThreshold": "early exit: the cradle's velocities off by ~1e-4",
    "enableConeFriction / useSplitImpulse / erp / frictionERP / deterministicOverlappingPairs":
        "no measured effect on these cases; set explicitly so the settings are known",
}


def box_bounds(walls):
    """(lo, hi) corners when the walls are the six faces of an axis-aligned box, else None."""
    if len(walls) != 6:
        return None
    lo, hi = [None] * 3, [None] * 3
    for w in walls:
        axis = int(np.argmax(np.abs(w.normal)))
        if abs(w.normal[axis]) != 1.0:
            return None
        side = lo if w.normal[axis] > 0 else hi
        if side[axis] is not None:
            return None
        side[axis] = w.point[axis]
    if any(v is None for v in lo + hi):
        return None
    return np.array(lo, float), np.array(hi, float)


def wall_slabs(walls, bodies):
    """(centre, half extents) per wall when the walls are the six faces of an axis-aligned box
    that holds every body centre; None otherwise (each wall is then an infinite plane).

    A slab lies outside the box, its inner face on the wall, overhanging the box's other faces
    by twice the largest radius, and as thick as the box (at least SLAB_MIN_THICKNESS): a
    sphere would have to tunnel through it to tell it from the half-space the wall stands for.
    """
    bounds = box_bounds(walls)
    if bounds is None:
        return None
    lo, hi = bounds
    x = np.array([b.position for b in bodies])
    if np.any(hi <= lo) or np.any(x < lo) or np.any(x > hi):
        return None
    pad = 2.0 * max(b.radius for b in bodies)
    thick = max(SLAB_MIN_THICKNESS, float(np.max(hi - lo)))
    slabs = []
    for w in walls:
        axis = int(np.argmax(np.abs(w.normal)))
        half = 0.5 * (hi - lo) + pad
        half[axis] = 0.5 * thick
        centre = 0.5 * (lo + hi)
        centre[axis] = w.point[axis] - w.normal[axis] * 0.5 * thick
        slabs.append((tuple(centre), tuple(half)))
    return slabs


def materials(contact):
    """Per-body values whose pair product is the scene's e and mu (Bullet multiplies)."""
    restitution, friction = per_shape_coefficients(contact)
    return dict(restitution=restitution, lateralFriction=friction,
                rollingFriction=0.0, spinningFriction=0.0)


def build_spheres(p, cid, bodies, contact):
    """One free btRigidBody per sphere (`bodies`: `Body` records), created in batches of equal
    (mass, radius) with `batchPositions`, then mass, inertia, the materials of the `contact`
    model, damping and velocities per body; (body id, -1) per body."""
    groups = {}
    for i, b in enumerate(bodies):
        groups.setdefault((b.mass, b.radius), []).append(i)
    uids = [None] * len(bodies)
    for (mass, radius), members in groups.items():
        shape = p.createCollisionShape(p.GEOM_SPHERE, radius=radius, physicsClientId=cid)
        made = p.createMultiBody(baseMass=mass, baseCollisionShapeIndex=shape,
                                 batchPositions=[bodies[i].position for i in members],
                                 useMaximalCoordinates=1, physicsClientId=cid)
        for i, uid in zip(members, made):
            uids[i] = uid
    per_body = materials(contact)
    for uid, b in zip(uids, bodies):
        p.changeDynamics(uid, -1, mass=b.mass, localInertiaDiagonal=(b.inertia,) * 3,
                         linearDamping=0.0, angularDamping=0.0,
                         activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING,
                         physicsClientId=cid, **per_body)
        p.resetBaseVelocity(uid, b.velocity, b.angular_velocity, physicsClientId=cid)
    return [(uid, -1) for uid in uids]


def build_walls(p, cid, walls, bodies, contact):
    """Static bodies for `walls` (`Wall` records, () for none) around `bodies` (`Body`
    records), with the `contact` model's materials: one box slab per face when the walls are an
    axis-aligned box holding the bodies (an infinite plane's AABB overlaps every sphere in the
    broad phase, so planes cost 2.2x the step at N = 1000), else one infinite GEOM_PLANE per
    wall. Returns what was built, in words."""
    if not walls:
        return "none"
    slabs = wall_slabs(walls, bodies)
    if slabs is not None:
        shapes = [(p.createCollisionShape(p.GEOM_BOX, halfExtents=half,
                                          physicsClientId=cid), centre)
                  for centre, half in slabs]
        built = ("6 static box slabs (GEOM_BOX) outside the box, inner faces on the walls, "
                 "as thick as the box")
    else:
        shapes = [(p.createCollisionShape(p.GEOM_PLANE, planeNormal=w.normal,
                                          physicsClientId=cid), w.point) for w in walls]
        built = f"{len(walls)} static infinite planes (GEOM_PLANE)"
    per_wall = materials(contact)
    for shape, where in shapes:
        uid = p.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=shape,
                                basePosition=where, useMaximalCoordinates=1,
                                physicsClientId=cid)
        p.changeDynamics(uid, -1, physicsClientId=cid, **per_wall)
    return built


def contact_settings(contact, inertias, walls_built):
    """The settings of a contact scene: its `contact` model, the spheres' `inertias` and the
    walls built (they replace some of the multibody ones)."""
    sqrt_e, sqrt_mu = per_shape_coefficients(contact)
    return {
        "integrator": dict(INTEGRATOR, native=("semi-implicit Euler (btRigidBody: "
                                               "velocities, contact impulses included, "
                                               "then positions)")),
        "python_per_step_note": ("one stepSimulation call from Python per step (plus the "
                                 "force calls, if any): the engine's real cost, timed"),
        "contact_model": "impulse",
        "detection": "discrete",
        "contact_solver": ("sequential impulses (projected Gauss-Seidel) on Newton's "
                           "restitution law + Coulomb friction, once per step, before the "
                           "positions move; contacts from the previous step's positions"),
        "restitution_mapping": (f"restitution sqrt(e) = {sqrt_e!r} on every "
                                f"sphere and wall (Bullet multiplies the pair's values)"),
        "friction_mapping": (f"lateralFriction sqrt(mu) = {sqrt_mu!r} on every "
                             f"sphere and wall (multiplied); rollingFriction = "
                             f"spinningFriction = 0"),
        "engine_parameters": dict(CONTACT_PARAMS),
        "changed_defaults": dict(CONTACT_DEFAULTS),
        "global_state": ("contactBreakingThreshold is process-global in Bullet "
                         "(gContactBreakingThreshold): set by every contact build"),
        "solver_iterations": CONTACT_PARAMS["numSolverIterations"],
        "ccd": ("off (ccdSweptSphereRadius = 0, the default): discrete detection; an "
                "oblique contact's normal is the overlapped pose's"),
        "formulation": ("free rigid bodies (btRigidBody, useMaximalCoordinates=1) with "
                        "GEOM_SPHERE shapes, created with batchPositions"),
        "useMaximalCoordinates": True,
        "inertia": ("the scene's, set with changeDynamics(mass, localInertiaDiagonal) "
                    "(without mass a maximal-coordinate body gets mass 0)"),
        "inertia_values": sorted(set(inertias)),  # distinct
        "collision_shapes": "GEOM_SPHERE per body; walls: " + walls_built,
        "maxJointVelocity": "n/a (rigid bodies have no speed clamp)",
    }
