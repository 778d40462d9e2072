"""pybullet (Bullet's Featherstone multibody, in DIRECT mode) behind the refsim contract.

Every body is its own `btMultiBody`: a free point mass is a floating base; a body on a rod is a
fixed base at the anchor with one revolute link whose centre of mass is the body (generalized
coordinates: the rod length is exact, so the constraint error is zero). pybullet steps with
semi-implicit Euler, velocities then positions ("kick-drift", refsim's `symplectic_euler`).

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


class PybulletEngine(Engine):
    name = "pybullet"
    package = "pybullet"
    capabilities = frozenset({"gravity", "springs", "joints", "drag"})
    dims = (3,)
    integrators = ("symplectic_euler",)

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
        return None

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
    """Import lazily: refsim works without pybullet installed."""
    import pybullet
    return pybullet


@contextlib.contextmanager
def _c_stdout_silenced():
    """pybullet's C code prints 'pybullet build time: ...' on stdout at the first connect;
    that line would land after `refsim run`'s last line (the run directory). Point fd 1 at
    /dev/null around the call and flush C's stdio buffer there before restoring it."""
    import ctypes
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            yield
            try:
                ctypes.CDLL(None).fflush(None)
            except (OSError, AttributeError):
                pass
    finally:
        os.dup2(saved, 1)
        os.close(saved)


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
        try:
            self.engine_params = self._configure_world()
            self.handles, self.hinges = self._build_bodies()
            self.forces = _ForceTerms(scene)
            self._apply = self.forces.applier(p, self.client, self.handles)
        except Exception:
            self.close()
            raise

    # -- model ---------------------------------------------------------------------------------
    def _configure_world(self):
        p, cid = self.p, self.client
        p.setGravity(*self.scene.gravity, physicsClientId=cid)
        p.setPhysicsEngineParameter(fixedTimeStep=self.dt, numSubSteps=0, physicsClientId=cid)
        return p.getPhysicsEngineParameters(physicsClientId=cid)  # effective values, read back

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
        if self.hinges:
            out.update(jointDamping=0.0, velocity_motor="off (VELOCITY_CONTROL, force=0)",
                       joint_limits="none", joint_angle="q = refsim's hinge angle theta "
                       "(joint axis -axis), set with resetJointState")
        return out

    def _stages(self):
        stages = ["gravity"] if any(self.scene.gravity) else []
        stages += self.forces.names() + (["revolute_generalized"] if self.hinges else [])
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
