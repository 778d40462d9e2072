"""pybullet (Bullet's Featherstone multibody, in DIRECT mode) behind the refsim contract.

Without contacts, every body is its own `btMultiBody`: a free point mass is a floating base; a
body on a rod is a fixed base at the anchor with one revolute link whose centre of mass is the
body (generalized coordinates: the rod length is exact, so the constraint error is zero).
pybullet steps with semi-implicit Euler, velocities then positions ("kick-drift", refsim's
`symplectic_euler`); with contacts, the bodies are rigid bodies (below), stepped the same way.

Facts applied, measured on pybullet 3.2.7 (ENGINE_NOTES.md):
- gravity defaults to 0 and the step to 1/240 s: both are set; `fixedTimeStep` is the whole step,
  `numSubSteps=0` (with sub-steps an explicit spring is unstable at any dt);
- multibodies carry speed-dependent damping 0.04: `linearDamping = angularDamping = 0` on the
  base and the link, `jointDamping = 0` on the joint;
- multibody speed is clamped at 100 m/s (`maxJointVelocity`): raised to infinity, so an
  instability shows instead of being clamped away (the k = 1e6 spring reaches 100 m/s);
- joint velocity motors act as friction: `VELOCITY_CONTROL` with `force = 0`;
- inertia is the scene's (0 for a point mass), set with `changeDynamics(localInertiaDiagonal)`;
  there are no collision shapes, so nothing is recomputed from a shape and nothing collides;
- no springs and no linear drag in the engine: the adapter applies them with
  `applyExternalForce` (WORLD_FRAME, at the centre of mass) before every `stepSimulation`,
  from the state at the start of the step (the force is cleared after every step). That is
  refsim's kick-drift exactly: v += h a(x, v); x += h v. Those Python calls are the engine's
  real cost in this use and are kept in the timing.

Contacts (features "contacts" and "walls"). Each sphere is a free `btRigidBody`
(`createMultiBody(useMaximalCoordinates=1)`, batch-created with `batchPositions`) with a
GEOM_SPHERE shape; a wall is a static body: a box slab per face when the walls are the six faces
of an axis-aligned box holding every body (an infinite GEOM_PLANE's AABB overlaps every sphere
in the broad phase: 2.2x slower at N = 1000), else a GEOM_PLANE. Bullet's sequential-impulse
solver then applies, at the start of every step, Newton's restitution law (target normal
separation e times the approach speed) with Coulomb friction at every contact found at the
positions reached by the previous step: discrete detection, an impulse model. Facts, measured
on pybullet 3.2.7 with the colliding_spheres case (each default below breaks the exact
outcome; the adapter changes it and says so in settings()):
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
- contact ERP (default: push-out velocity, an e = 0.5 impact came out 10 % fast; ENGINE_NOTES
  3-12 %): `contactERP = erp = frictionERP = 0`, split impulse off, so overlaps are never pushed
  out and velocities change only by the impacts;
- `solverResidualThreshold` (default: the solver stops early) 0, 50 iterations: simultaneous
  contacts (the cradle) are solved to convergence; a lone contact is exact after one;
- `changeDynamics(localInertiaDiagonal=...)` on a maximal-coordinate body without `mass` sets the
  mass to 0 (the step then gives NaN): mass and inertia are set together, the scene's inertia;
- damping set to 0, sleeping disabled; CCD off (the default; at these speeds a body moves a
  hundredth of its radius per step).
A lone impact is then the exact impulse law with the normal of the overlapped pose: head-on
outcomes are exact to round-off at any dt, an oblique one is tilted by the overlap (O(dt)).
Stepping is one `stepSimulation` Python call per step (plus the force calls above, if any).
"""
from __future__ import annotations

import contextlib
import math
import os
import sys

import numpy as np

from refsim.engine import Engine, Sim
from refsim.models.joints import cartesian_to_hinge, hinge_frame

INTEGRATOR = {"name": "symplectic_euler", "order": 1, "family": "symplectic Euler",
              "explicit": True, "symplectic": True,
              "native": "semi-implicit Euler (btMultiBody: velocities, then positions)"}
MAX_SPEED = math.inf  # replaces pybullet's 100 m/s multibody clamp
_ZERO = (0.0, 0.0, 0.0)
ROD_RTOL = 1e-9  # a body this far (relative) off its rod's circle is refused, not projected

# Contact scenes: setPhysicsEngineParameter values (pybullet 3.2.7; reasons in the docstring).
# contactBreakingThreshold is Bullet's global gContactBreakingThreshold: it holds for every
# client in the process, so every contact build sets it (nothing else in refsim changes it).
CONTACT_PARAMS = {
    "contactERP": 0.0, "erp": 0.0, "frictionERP": 0.0, "useSplitImpulse": 0,
    "contactSlop": 0.0, "contactBreakingThreshold": 1e-12, "restitutionVelocityThreshold": 0.0,
    "numSolverIterations": 50, "solverResidualThreshold": 0.0, "enableConeFriction": 1,
    "deterministicOverlappingPairs": 1,
}
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


class PybulletEngine(Engine):
    name = "pybullet"
    package = "pybullet"
    capabilities = frozenset({"gravity", "springs", "joints", "drag", "contacts", "walls"})
    dims = (3,)
    integrators = ("symplectic_euler",)

    def available(self) -> bool:
        try:
            _import_pybullet()
        except ImportError:
            return False
        return True

    def supports(self, scene, integrator=None):
        reason = super().supports(scene, integrator)
        if reason:
            return reason
        if integrator is not None and integrator != "symplectic_euler":
            return f"pybullet's symplectic_euler takes no parameter, got {integrator!r}"
        rod_bodies = [j.body for j in scene.joints]
        if len(set(rod_bodies)) != len(rod_bodies):
            return "pybullet adapter: one rod per body (two rods on a body form a closed loop)"
        for j in scene.joints:
            why = _rod_mismatch(scene, j)
            if why:
                return why
        return _contact_mismatch(scene)

    def build(self, scene, dt, integrator, variant=""):
        dt = float(dt)
        if not math.isfinite(dt) or dt <= 0:
            raise ValueError(f"dt must be a finite number > 0, got {dt}")
        if variant != "":
            raise ValueError(f"pybullet variant must be one of [''], got {variant!r}")
        reason = self.supports(scene, integrator)
        if reason:
            raise ValueError(reason)
        return PybulletSim(_import_pybullet(), scene, dt)


def _import_pybullet():
    """Import lazily (refsim works without pybullet installed), with its C-level
    'pybullet build time' line kept off stdout."""
    with _c_stdout_silenced():
        import pybullet
    return pybullet


@contextlib.contextmanager
def _c_stdout_silenced():
    """pybullet's C code prints 'pybullet build time: ...' at import and at the first
    connect; on stdout that line would land after `refsim run`'s last line (the run
    directory). Point fds 1 and 2 at /dev/null around the call and flush C's stdio buffers
    there before restoring them (Python exceptions still propagate)."""
    import ctypes
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            os.dup2(null.fileno(), 2)
            yield
            try:
                ctypes.CDLL(None).fflush(None)
            except (OSError, AttributeError):
                pass
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in saved:
            os.close(fd)


def _contact_mismatch(scene):
    """A reason when the adapter cannot build the scene's contacts faithfully, else None."""
    if scene.walls and scene.contact is None:
        return "pybullet adapter: walls need a contact model (scene.contact: e and mu)"
    if scene.contact is None:
        return None
    if scene.joints:
        return ("pybullet adapter: contacts are built for free spheres only (a body on a rod "
                "is a multibody link without a collision shape)")
    for i, b in enumerate(scene.bodies):
        if b.radius <= 0:
            return (f"pybullet adapter: every body of a contact scene must be a sphere "
                    f"(radius > 0); body {i} has radius {b.radius:g}")
        if b.inertia <= 0 and scene.contact.friction > 0:
            return (f"pybullet adapter: body {i} has zero inertia under friction; Bullet reads "
                    f"a zero inertia as infinite (no spin), not as zero")
    return None


def _wall_slabs(walls, bodies):
    """(centre, half extents) per wall when the walls are the six faces of an axis-aligned box
    that holds every body centre; None otherwise (each wall is then an infinite plane).

    A slab lies outside the box, its inner face on the wall, overhanging the box's other faces
    by twice the largest radius, and as thick as the box (at least SLAB_MIN_THICKNESS): a
    sphere would have to tunnel through it to tell it from the half-space the wall stands for.
    """
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
    lo, hi = np.array(lo, float), np.array(hi, float)
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


def _rod_mismatch(scene, joint):
    """A reason when the body is not on the rod's circle or moves off the hinge's arc (a
    revolute joint cannot hold that state); None when the hinge represents it exactly."""
    body = scene.bodies[joint.body]
    r = np.subtract(body.position, joint.anchor)
    axis = np.asarray(joint.axis)
    scale = joint.length
    if abs(np.linalg.norm(r) - joint.length) > ROD_RTOL * scale or \
            abs(r @ axis) > ROD_RTOL * scale:
        return (f"pybullet adapter: body {joint.body} is not on its rod's circle (distance "
                f"{np.linalg.norm(r):.6g} m from the anchor, rod length {joint.length:.6g} m)")
    v = np.asarray(body.velocity)
    if abs(v @ r) > ROD_RTOL * scale * max(1.0, np.linalg.norm(v)) or \
            abs(v @ axis) > ROD_RTOL * max(1.0, np.linalg.norm(v)):
        return f"pybullet adapter: body {joint.body}'s velocity leaves the hinge's arc"
    return None


class PybulletSim(Sim):
    def __init__(self, p, scene, dt):
        self.p, self.scene, self.dt, self.steps = p, scene, dt, 0
        with _c_stdout_silenced():
            self.client = p.connect(p.DIRECT)
        self.contact = scene.contact
        self.walls_built = "none"
        try:
            self.engine_params = self._configure_world()
            if self.contact is not None:
                self.handles, self.hinges = self._sphere_bodies(), []
                self._build_walls()
            else:
                self.handles, self.hinges = self._build_bodies()
            self.forces = _ForceTerms(scene)
            self._apply = self.forces.applier(p, self.client, self.handles)
        except Exception:
            self.close()
            raise

    # -- world ---------------------------------------------------------------------------------
    def _configure_world(self):
        p, cid = self.p, self.client
        p.setGravity(*self.scene.gravity, physicsClientId=cid)
        p.setPhysicsEngineParameter(fixedTimeStep=self.dt, numSubSteps=0, physicsClientId=cid)
        if self.contact is not None:
            p.setPhysicsEngineParameter(**CONTACT_PARAMS, physicsClientId=cid)
        return p.getPhysicsEngineParameters(physicsClientId=cid)  # effective values, read back

    # -- contacts ------------------------------------------------------------------------------
    def _materials(self):
        """Per-body values whose pair product is the scene's e and mu (Bullet multiplies)."""
        return dict(restitution=math.sqrt(self.contact.restitution),
                    lateralFriction=math.sqrt(self.contact.friction),
                    rollingFriction=0.0, spinningFriction=0.0)

    def _sphere_bodies(self):
        """One free btRigidBody per sphere, created in batches of equal (mass, radius) with
        `batchPositions`, then mass, inertia, materials, damping and velocities per body."""
        p, cid, bodies = self.p, self.client, self.scene.bodies
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
        materials = self._materials()
        for uid, b in zip(uids, bodies):
            p.changeDynamics(uid, -1, mass=b.mass, localInertiaDiagonal=(b.inertia,) * 3,
                             linearDamping=0.0, angularDamping=0.0,
                             activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING,
                             physicsClientId=cid, **materials)
            p.resetBaseVelocity(uid, b.velocity, b.angular_velocity, physicsClientId=cid)
        return [(uid, -1) for uid in uids]

    def _build_walls(self):
        """Static bodies: one box slab per face when the walls are an axis-aligned box holding
        the bodies (an infinite plane's AABB overlaps every sphere in the broad phase, so planes
        cost 2.2x the step at N = 1000), else one infinite GEOM_PLANE per wall."""
        p, cid, walls = self.p, self.client, self.scene.walls
        if not walls:
            return
        slabs = _wall_slabs(walls, self.scene.bodies)
        if slabs is not None:
            shapes = [(p.createCollisionShape(p.GEOM_BOX, halfExtents=half,
                                              physicsClientId=cid), centre)
                      for centre, half in slabs]
            self.walls_built = ("6 static box slabs (GEOM_BOX) outside the box, inner faces on "
                                "the walls, as thick as the box")
        else:
            shapes = [(p.createCollisionShape(p.GEOM_PLANE, planeNormal=w.normal,
                                              physicsClientId=cid), w.point) for w in walls]
            self.walls_built = f"{len(walls)} static infinite planes (GEOM_PLANE)"
        materials = self._materials()
        for shape, where in shapes:
            uid = p.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=shape,
                                    basePosition=where, useMaximalCoordinates=1,
                                    physicsClientId=cid)
            p.changeDynamics(uid, -1, physicsClientId=cid, **materials)

    # -- model (no contacts) -------------------------------------------------------------------
    def _build_bodies(self):
        """(multibody id, link index) per scene body: -1 for a free base, 0 for a rod's link."""
        rods = {j.body: j for j in self.scene.joints}
        handles, hinges = [], []
        for i, body in enumerate(self.scene.bodies):
            if i in rods:
                handles.append((self._hinge_body(body, rods[i]), 0))
                hinges.append(i)
            else:
                handles.append((self._free_body(body), -1))
        return handles, hinges

    def _free_body(self, body):
        p, cid = self.p, self.client
        uid = p.createMultiBody(baseMass=body.mass, baseCollisionShapeIndex=-1,
                                baseVisualShapeIndex=-1, basePosition=body.position,
                                physicsClientId=cid)
        self._exact_dynamics(uid, -1, body.inertia)
        p.resetBaseVelocity(uid, body.velocity, body.angular_velocity, physicsClientId=cid)
        return uid

    def _hinge_body(self, body, joint):
        """Fixed base at the anchor, one revolute link; the link's centre of mass (the body) at
        L d for q = 0, d hanging along gravity in the hinge plane. The joint axis is -axis, so
        q turns d towards s = d x axis: q is refsim's hinge angle theta."""
        p, cid = self.p, self.client
        d, s, _ = hinge_frame(joint.axis, self.scene.gravity)
        uid = p.createMultiBody(
            baseMass=0.0, baseCollisionShapeIndex=-1, baseVisualShapeIndex=-1,
            basePosition=joint.anchor, linkMasses=[body.mass], linkCollisionShapeIndices=[-1],
            linkVisualShapeIndices=[-1], linkPositions=[(0.0, 0.0, 0.0)],
            linkOrientations=[(0.0, 0.0, 0.0, 1.0)],
            linkInertialFramePositions=[tuple(joint.length * d)],
            linkInertialFrameOrientations=[(0.0, 0.0, 0.0, 1.0)], linkParentIndices=[0],
            linkJointTypes=[p.JOINT_REVOLUTE], linkJointAxis=[tuple(-np.asarray(joint.axis))],
            useMaximalCoordinates=0, physicsClientId=cid)
        self._exact_dynamics(uid, -1, None)  # the fixed base: no inertia to set
        self._exact_dynamics(uid, 0, body.inertia)
        p.setJointMotorControl2(uid, 0, p.VELOCITY_CONTROL, force=0.0, physicsClientId=cid)
        theta, omega = cartesian_to_hinge(np.asarray(body.position), np.asarray(body.velocity),
                                          np.asarray(joint.anchor), joint.length, d, s)
        p.resetJointState(uid, 0, float(theta), float(omega), physicsClientId=cid)
        return uid

    def _exact_dynamics(self, uid, link, inertia):
        """ENGINE_NOTES (pybullet 3.2.7): damping off, 100 m/s clamp raised, inertia as given
        (None for a fixed base), no sleeping."""
        kw = dict(linearDamping=0.0, angularDamping=0.0, maxJointVelocity=MAX_SPEED,
                  activationState=self.p.ACTIVATION_STATE_DISABLE_SLEEPING,
                  physicsClientId=self.client)
        if link >= 0:
            kw["jointDamping"] = 0.0
        if inertia is not None:
            kw["localInertiaDiagonal"] = (inertia,) * 3
        self.p.changeDynamics(uid, link, **kw)

    # -- contract ------------------------------------------------------------------------------
    def step(self, n):
        step, cid, apply = self.p.stepSimulation, self.client, self._apply
        if apply is None:
            for _ in range(int(n)):
                step(physicsClientId=cid)
        else:
            for _ in range(int(n)):
                apply()
                step(physicsClientId=cid)
        self.steps += int(n)

    def observe(self):
        states = [_body_state(self.p, self.client, uid, link) for uid, link in self.handles]
        out = {"t": self.steps * self.dt, "x": np.array([s[0] for s in states], float),
               "v": np.array([s[1] for s in states], float)}
        if self.scene.joints:
            out["constraint"] = np.zeros(len(self.scene.joints))  # generalized coordinates
        if self.contact is not None:
            out["w"] = np.array([self.p.getBaseVelocity(uid, physicsClientId=self.client)[1]
                                 for uid, _ in self.handles], float)
        return out

    def settings(self):
        prm = self.engine_params
        out = {
            "integrator": dict(INTEGRATOR), "dtype": "float64", "threads": 1,
            "dtype_note": ("pybullet wheels are double precision: free fall and springs agree "
                           "with refsim's float64 kick-drift bit for bit"),
            "connection": "DIRECT", "fixedTimeStep": prm["fixedTimeStep"],
            "numSubSteps": prm["numSubSteps"],
            "gravity": [prm[f"gravityAcceleration{c}"] for c in "XYZ"],
            "formulation": ("generalized coordinates: fixed base at the anchor + revolute link "
                            "per rod (Featherstone)" if self.hinges else "free multibody base"),
            "useMaximalCoordinates": False,
            "linearDamping": 0.0, "angularDamping": 0.0,
            "maxJointVelocity": "inf (default 100 m/s clamp removed)",
            "inertia": "as given by the scene (0 for a point mass) via localInertiaDiagonal",
            "inertia_values": [b.inertia for b in self.scene.bodies],
            "collision_shapes": "none (nothing collides; no ground plane)",
            "sleeping": "disabled",
            "stages": self._stages(),
            **self.forces.describe(self.handles),
        }
        if self.contact is not None:
            out.update(self._contact_settings())
        if self.hinges:
            out.update(jointDamping=0.0, velocity_motor="off (VELOCITY_CONTROL, force=0)",
                       joint_limits="none", joint_angle="q = refsim's hinge angle theta "
                       "(joint axis -axis), set with resetJointState")
        return out

    def _contact_settings(self):
        e, mu = self.contact.restitution, self.contact.friction
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
            "restitution_mapping": (f"restitution sqrt(e) = {math.sqrt(e)!r} on every "
                                    f"sphere and wall (Bullet multiplies the pair's values)"),
            "friction_mapping": (f"lateralFriction sqrt(mu) = {math.sqrt(mu)!r} on every "
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
            "inertia_values": sorted({b.inertia for b in self.scene.bodies}),  # distinct
            "collision_shapes": "GEOM_SPHERE per body; walls: " + self.walls_built,
            "maxJointVelocity": "n/a (rigid bodies have no speed clamp)",
        }

    def _stages(self):
        stages = ["gravity"] if any(self.scene.gravity) else []
        stages += self.forces.names() + (["revolute_generalized"] if self.hinges else [])
        if self.contact is not None:
            stages += ["contacts:discrete_detection", "contacts:impulses"]
        return stages + ["integrate:symplectic_euler"]

    def close(self):
        if self.client is not None:
            try:
                self.p.disconnect(physicsClientId=self.client)
            except Exception:  # already gone (interpreter shutdown)
                pass
            self.client = None

    def __del__(self):
        self.close()


def _body_state(p, cid, uid, link, velocity=True):
    """(centre-of-mass position, its velocity or None) in the world frame."""
    if link < 0:
        x = p.getBasePositionAndOrientation(uid, physicsClientId=cid)[0]
        return x, (p.getBaseVelocity(uid, physicsClientId=cid)[0] if velocity else None)
    state = p.getLinkState(uid, link, computeLinkVelocity=int(velocity),
                           computeForwardKinematics=1, physicsClientId=cid)
    return state[0], (state[6] if velocity else None)


class _ForceTerms:
    """Springs and linear drag, which pybullet lacks, as per-step external forces.

    Plain Python on tuples (not numpy): for one or two bodies this is several times cheaper, so
    the timing is pybullet's call overhead rather than the adapter's arithmetic."""

    def __init__(self, scene):
        self.springs = [(s.body, s.other, s.anchor, s.stiffness, s.rest_length, s.damping)
                        for s in scene.springs]
        self.drag = scene.linear_drag
        self.nbody = len(scene.bodies)
        needed = {s[0] for s in self.springs} | {s[1] for s in self.springs if s[1] is not None}
        self.bodies = sorted(range(self.nbody) if self.drag > 0 else needed)
        self.needs_v = self.drag > 0 or any(s[5] > 0 for s in self.springs)

    def names(self):
        return (["drag (external force)"] if self.drag > 0 else []) + \
            (["springs (external force)"] if self.springs else [])

    def describe(self, handles):
        if not self.bodies:
            return {"python_calls_per_step": 1, "external_forces": "none"}
        # stepSimulation, then per forced body: its state (a free base reads position and,
        # when a force needs it, velocity apart; a link both at once) and one force
        free_reads = 2 if self.needs_v else 1
        calls = 1 + sum(1 + (free_reads if handles[i][1] < 0 else 1) for i in self.bodies)
        return {
            "external_forces": self.names(),
            "external_force_method": (
                "applyExternalForce(WORLD_FRAME, at the centre of mass) before every "
                "stepSimulation, from the state at the start of the step (force cleared after "
                "every step): kick-drift, refsim's symplectic_euler"),
            "python_calls_per_step": calls,
            "python_per_step_note": ("pybullet has no springs or linear drag: a Python round "
                                     "trip per body per step (state read, force write) is the "
                                     "engine's real cost in this use, kept in the timing"),
        }

    def forces(self, x, v):
        """Force per body in self.bodies (a dict of 3-lists), from the positions and velocities
        (tuples) of every body."""
        drag = self.drag
        f = {i: ([-drag * c for c in v[i]] if drag else [0.0, 0.0, 0.0]) for i in self.bodies}
        for body, other, anchor, k, rest, c in self.springs:
            free = other is None
            fs = _spring_force(x[body], anchor if free else x[other], v[body],
                               _ZERO if free or not c else v[other], k, rest, c)
            fb = f[body]
            fb[0] += fs[0]
            fb[1] += fs[1]
            fb[2] += fs[2]
            if not free:
                fo = f[other]
                fo[0] -= fs[0]
                fo[1] -= fs[1]
                fo[2] -= fs[2]
        return f

    def applier(self, p, cid, handles):
        """A no-argument function applying this step's forces, or None when there are none."""
        if not self.bodies:
            return None
        apply, world = p.applyExternalForce, p.WORLD_FRAME
        x, v = [None] * self.nbody, [None] * self.nbody
        needs_v = self.needs_v

        def apply_forces():
            for i in self.bodies:
                x[i], v[i] = _body_state(p, cid, *handles[i], velocity=needs_v)
            for i, force in self.forces(x, v).items():
                uid, link = handles[i]
                apply(uid, link, force, x[i], world, physicsClientId=cid)
        return apply_forces


def _spring_force(x, xo, v, vo, k, rest, c):
    """-k (|d| - L0) u - c (dv . u) u on the body end, d = x - xo, u = d / |d| (0 when |d| = 0)."""
    d = (x[0] - xo[0], x[1] - xo[1], x[2] - xo[2])
    length = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    if length == 0.0:
        return (0.0, 0.0, 0.0)
    u = (d[0] / length, d[1] / length, d[2] / length)
    scale = -k * (length - rest)
    if c:
        dv = (v[0] - vo[0], v[1] - vo[1], v[2] - vo[2])
        scale -= c * (dv[0] * u[0] + dv[1] * u[1] + dv[2] * u[2])
    return (scale * u[0], scale * u[1], scale * u[2])
