"""MuJoCo behind refsim's engine contract (measured on mujoco 4.0.0).

Each scene becomes an MJCF model with one MuJoCo body per scene body, no geoms and contacts off:
- a free point mass: three slide joints (x, y, z), so the mass matrix is m I exactly;
- a mass on a spring to a fixed anchor: one slide joint along the anchor-body line with
  `stiffness` k, `springref` at the rest length and `damping` c (the spring's own damping);
- a mass on a rod: one hinge joint through the anchor (generalized coordinate, no constraint).
Linear drag f = -b v is joint damping: b on each slide, b L^2 on a hinge (exact for a point mass).
The body's reference pose (qpos = 0) is the scene's initial pose, so refsim's positions need no
sign or offset conventions and MuJoCo's own reset target is the initial state.

Facts applied (ENGINE_NOTES.md, mujoco 4.0.0), each reported in `Sim.settings()`:
- gravity and timestep are set explicitly (MuJoCo defaults: -9.81 z, 0.002 s);
- a point mass gets an explicit `<inertial>` with diaginertia 1e-12 (1e-9 showed a 1e-8 error
  under RK4), never inertia from geoms;
- `Euler` treats joint damping implicitly unless the `eulerdamp` flag is disabled (mujoco 4.0.0
  docs, Numerical integration): it is disabled, so "symplectic_euler" is refsim's kick-drift
  step with every force explicit; `implicit`/`implicitfast` keep damping implicit, their method;
- on NaN/Inf/huge values MuJoCo warns, resets to the initial pose and writes MUJOCO_LOG.TXT in
  the working directory: auto-reset is disabled, the bad-qpos/qvel/qacc warning counters are read
  after every `step(n)` and set `Sim.failure`, and MuJoCo's warnings go to a callback while
  stepping (no log file, no console output).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from refsim.engine import Engine, Sim

POINT_INERTIA = 1e-12  # kg m^2: ENGINE_NOTES (1e-12 clean, 1e-9 a 1e-8 error under RK4)
_GEOMETRY_RTOL = 1e-9  # initial state must satisfy a rod / stay on a spring's line to this


@dataclass(frozen=True)
class Method:
    """One MuJoCo integrator as refsim declares it."""

    native: str  # mjtIntegrator member
    xml: str  # MJCF option value
    order: int
    family: str
    explicit: bool
    symplectic: bool
    note: str


METHODS = {
    "symplectic_euler": Method(
        "mjINT_EULER", "Euler", 1, "symplectic Euler", True, True,
        "semi-implicit Euler, kick then drift (v += h a(x, v); q += h v); eulerdamp disabled, "
        "so joint damping is explicit too"),
    "rk4": Method(
        "mjINT_RK4", "RK4", 4, "explicit Runge-Kutta", True, False,
        "classical 4-stage Runge-Kutta on (q, v)"),
    "implicit": Method(
        "mjINT_IMPLICIT", "implicit", 1, "implicit-in-velocity Euler", False, False,
        "(M + h D) dv = h (f - ...): damping and Coriolis derivatives implicit, stiffness "
        "explicit, so an undamped spring keeps Euler's omega dt < 2 limit; with nothing damped "
        "it is the symplectic_euler step"),
    "implicitfast": Method(
        "mjINT_IMPLICITFAST", "implicitfast", 1, "implicit-in-velocity Euler (no RNE "
        "derivatives)", False, False,
        "as implicit without the Coriolis/centripetal derivatives; here it equals MuJoCo's "
        "default Euler (eulerdamp on): damping implicit, springs explicit"),
    "discrete": Method(
        "mjINT_DISCRETE", "discrete", 1, "linearised backward Euler (heavily damping)", False,
        False,
        "step solved in M + h D + h^2 K: joint stiffness and damping implicit, so springs are "
        "stable at any dt but lose energy by 1/(1 + (omega dt)^2) per step (backward Euler); "
        "gravity stays explicit. Unconditionally stable, misleading as an accuracy figure"),
}

_BAD_WARNINGS = ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC", "mjWARN_INERTIA")


# ---------------------------------------------------------------------------------------------
# Scene -> per-body joint plan (also the single source of `supports` reasons)
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BodyPlan:
    kind: str  # "particle", "spring" or "hinge"
    index: int
    mass: float
    position: tuple
    axis: tuple = (0.0, 0.0, 0.0)  # slide axis (spring) or hinge axis
    joint_pos: tuple = (0.0, 0.0, 0.0)  # hinge point in the body frame
    stiffness: float = 0.0
    springref: float = 0.0
    damping: float = 0.0
    qvel0: tuple = ()

    def describe(self) -> dict:
        text = {"particle": "3 slide joints (x, y, z): exact point-mass translation",
                "spring": "1 slide joint along the anchor-body line, joint stiffness/springref",
                "hinge": "1 hinge joint through the anchor: generalized coordinate"}[self.kind]
        return {"body": self.index, "formulation": text, "axis": list(self.axis),
                "stiffness": self.stiffness, "springref": self.springref,
                "joint_damping": self.damping}


def plan_scene(scene) -> list[BodyPlan]:
    """One plan per body; ValueError with a one-sentence reason when it cannot be faithful."""
    springs = {}
    for s in scene.springs:
        if s.other is not None:
            raise ValueError("mujoco adapter: springs between two bodies are not modelled "
                             "(a joint spring needs a fixed anchor)")
        if s.body in springs:
            raise ValueError("mujoco adapter: at most one spring per body (a slide-joint "
                             "spring moves along one line)")
        springs[s.body] = s
    joints = {}
    for j in scene.joints:
        if j.body in joints or j.body in springs:
            raise ValueError("mujoco adapter: a body may carry one rod or one spring, not both "
                             "or several")
        joints[j.body] = j
    plans = []
    for i, body in enumerate(scene.bodies):
        if i in joints:
            plans.append(_hinge_plan(scene, i, body, joints[i]))
        elif i in springs:
            plans.append(_spring_plan(scene, i, body, springs[i]))
        else:
            plans.append(BodyPlan("particle", i, body.mass, body.position,
                                  damping=scene.linear_drag, qvel0=body.velocity))
    return plans


def _hinge_plan(scene, i, body, joint) -> BodyPlan:
    """Hinge through the anchor; qpos = 0 is the initial pose, qvel the initial rate."""
    r0 = np.subtract(body.position, joint.anchor)
    axis, length = np.asarray(joint.axis), joint.length
    tol = _GEOMETRY_RTOL * length
    if abs(np.linalg.norm(r0) - length) > tol or abs(r0 @ axis) > tol:
        raise ValueError("mujoco adapter: a rod body must start at distance L from the anchor, "
                         "perpendicular to the hinge axis")
    omega = float(np.cross(r0, body.velocity) @ axis) / length ** 2
    speed = max(np.linalg.norm(body.velocity), 1.0)
    if np.linalg.norm(np.cross(omega * axis, r0) - body.velocity) > _GEOMETRY_RTOL * speed:
        raise ValueError("mujoco adapter: a rod body's initial velocity must be a rotation "
                         "about the hinge axis")
    return BodyPlan("hinge", i, body.mass, body.position, axis=tuple(axis),
                    joint_pos=tuple(-r0), damping=scene.linear_drag * length ** 2,
                    qvel0=(omega,))


def _spring_plan(scene, i, body, spring) -> BodyPlan:
    """Slide along u = (x0 - anchor)/d0; spring force -k (q + d0 - L0) = -k (d - L0)."""
    r0 = np.subtract(body.position, spring.anchor)
    d0 = float(np.linalg.norm(r0))
    if d0 == 0:
        raise ValueError("mujoco adapter: a spring body may not start on its anchor")
    u = r0 / d0
    v0, g = np.asarray(body.velocity), np.asarray(scene.gravity)
    if np.linalg.norm(v0 - (v0 @ u) * u) > _GEOMETRY_RTOL * max(np.linalg.norm(v0), 1.0) or \
            np.linalg.norm(g - (g @ u) * u) > _GEOMETRY_RTOL * max(np.linalg.norm(g), 1.0):
        raise ValueError("mujoco adapter: a spring body must move along the anchor-body line "
                         "(velocity and gravity along it); a slide-joint spring is 1D")
    if _closest_approach(body.mass, spring.stiffness, spring.rest_length, g @ u, d0,
                         v0 @ u) <= 0:
        raise ValueError("mujoco adapter: this spring would swing through its anchor, which a "
                         "slide-joint spring does not model")
    return BodyPlan("spring", i, body.mass, body.position, axis=tuple(u),
                    stiffness=spring.stiffness, springref=spring.rest_length - d0,
                    damping=spring.damping + scene.linear_drag, qvel0=(float(v0 @ u),))


def _closest_approach(m, k, rest, g_u, d0, v0):
    """Smallest anchor distance of the undamped 1D motion (damping only lowers the energy)."""
    centre = rest + m * g_u / k
    amplitude = math.sqrt((d0 - centre) ** 2 + m * v0 * v0 / k)
    return centre - amplitude


# ---------------------------------------------------------------------------------------------
# MJCF
# ---------------------------------------------------------------------------------------------
def _fmt(values) -> str:
    return " ".join(repr(float(c)) for c in np.atleast_1d(values))


def _body_xml(plan: BodyPlan) -> str:
    inertial = (f'<inertial pos="0 0 0" mass="{_fmt(plan.mass)}" '
                f'diaginertia="{_fmt([POINT_INERTIA] * 3)}"/>')
    if plan.kind == "particle":
        joints = "".join(f'<joint name="b{plan.index}_{n}" type="slide" axis="{a}" '
                         f'damping="{_fmt(plan.damping)}"/>'
                         for n, a in (("x", "1 0 0"), ("y", "0 1 0"), ("z", "0 0 1")))
    elif plan.kind == "spring":
        joints = (f'<joint name="b{plan.index}_spring" type="slide" axis="{_fmt(plan.axis)}" '
                  f'stiffness="{_fmt(plan.stiffness)}" springref="{_fmt(plan.springref)}" '
                  f'damping="{_fmt(plan.damping)}"/>')
    else:
        joints = (f'<joint name="b{plan.index}_hinge" type="hinge" pos="{_fmt(plan.joint_pos)}" '
                  f'axis="{_fmt(plan.axis)}" damping="{_fmt(plan.damping)}"/>')
    return f'<body name="b{plan.index}" pos="{_fmt(plan.position)}">{inertial}{joints}</body>'


def scene_xml(scene, plans, dt: float, method: Method) -> str:
    """MJCF: explicit timestep and gravity, no fluid forces, contacts/eulerdamp/autoreset off."""
    bodies = "".join(_body_xml(p) for p in plans)
    return (f'<mujoco model="refsim"><option timestep="{_fmt(dt)}" '
            f'gravity="{_fmt(scene.gravity)}" integrator="{method.xml}" density="0" '
            f'viscosity="0" wind="0 0 0"><flag contact="disable" eulerdamp="disable" '
            f'autoreset="disable"/></option><worldbody>{bodies}</worldbody></mujoco>')


# ---------------------------------------------------------------------------------------------
# Engine
# ---------------------------------------------------------------------------------------------
class MujocoEngine(Engine):
    name = "mujoco"
    package = "mujoco"
    capabilities = frozenset({"gravity", "springs", "joints", "drag"})
    dims = (3,)
    integrators = tuple(METHODS)

    def supports(self, scene, integrator=None):
        reason = super().supports(scene, integrator)
        if reason:
            return reason
        try:
            plan_scene(scene)
        except ValueError as exc:
            return str(exc)
        return None

    def build(self, scene, dt, integrator, variant=""):
        if integrator not in METHODS:
            raise ValueError(f"mujoco integrator must be one of {list(METHODS)}, "
                             f"got {integrator!r}")
        if variant:
            raise ValueError(f"mujoco variant must be one of [''], got {variant!r}")
        dt = float(dt)
        if not math.isfinite(dt) or dt <= 0:
            raise ValueError(f"dt must be a finite number > 0, got {dt}")
        return MujocoSim(scene, plan_scene(scene), dt, integrator)


class MujocoSim(Sim):
    def __init__(self, scene, plans, dt, integrator):
        import mujoco
        self.mj, self.scene, self.plans, self.dt = mujoco, scene, plans, dt
        self.integrator, self.method = integrator, METHODS[integrator]
        self.steps, self.failure, self._messages = 0, None, []
        xml = scene_xml(scene, plans, dt, self.method)
        t0 = time.perf_counter()
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.compile_s = time.perf_counter() - t0
        self._check_model()
        self.data = mujoco.MjData(self.model)
        self.data.qvel[:] = np.concatenate([p.qvel0 for p in plans])
        self._bad = np.array([int(getattr(mujoco.mjtWarning, w)) for w in _BAD_WARNINGS])
        self._counts = self.data.warning.number  # a live view of mjData.warning[:].number
        self._vel = np.zeros(6)

    def _check_model(self):
        """The compiled options are the ones asked for (MuJoCo's defaults differ)."""
        opt, mj = self.model.opt, self.mj
        wanted = int(getattr(mj.mjtIntegrator, self.method.native))
        flags = [int(getattr(mj.mjtDisableBit, f)) for f in
                 ("mjDSBL_CONTACT", "mjDSBL_EULERDAMP", "mjDSBL_AUTORESET")]
        if opt.timestep != self.dt or not np.array_equal(opt.gravity, self.scene.gravity) or \
                opt.integrator != wanted or not all(opt.disableflags & f for f in flags):
            raise RuntimeError("mujoco compiled other options than the adapter asked for")

    def step(self, n):
        if self.failure or n <= 0:
            return
        mj = self.mj
        previous = mj.get_mju_user_warning()
        mj.set_mju_user_warning(self._messages.append)  # no MUJOCO_LOG.TXT, no console
        try:
            mj.mj_step(self.model, self.data, nstep=int(n))
        finally:
            mj.set_mju_user_warning(previous)
        self.steps += int(n)
        self._check_warnings()

    def _check_warnings(self):
        counts = self._counts[self._bad]
        if counts.any():
            names = [w for w, c in zip(_BAD_WARNINGS, counts) if c]
            text = "; ".join(m.strip() for m in self._messages) or "no message"
            self.failure = f"mujoco reported {', '.join(names)} ({text})"

    def observe(self):
        mj, m, d = self.mj, self.model, self.data
        mj.mj_kinematics(m, d)
        mj.mj_comPos(m, d)
        mj.mj_comVel(m, d)
        n = len(self.plans)
        x, v = d.xipos[1:n + 1].copy(), np.empty((n, 3))
        for i in range(n):
            mj.mj_objectVelocity(m, d, mj.mjtObj.mjOBJ_BODY, i + 1, self._vel, 0)
            v[i] = self._vel[3:]
        out = {"t": self.steps * self.dt, "x": x, "v": v}
        if self.scene.joints:
            out["constraint"] = np.zeros(len(self.scene.joints))  # generalized coordinates
        return out

    def settings(self):
        m = self.method
        return {
            "integrator": {"name": self.integrator, "order": m.order, "family": m.family,
                           "explicit": m.explicit, "symplectic": m.symplectic,
                           "native": m.native, "note": m.note},
            "dtype": "float64", "threads": 1,
            "timestep": self.dt, "timestep_default_replaced": 0.002,
            "gravity": list(self.scene.gravity), "gravity_default_replaced": [0.0, 0.0, -9.81],
            "eulerdamp": "disabled (Euler would otherwise treat joint damping implicitly)",
            "autoreset": "disabled; bad qpos/qvel/qacc warning counters checked after every "
                         "step(n) and reported as a failure",
            "warnings": "routed to a callback while stepping: no MUJOCO_LOG.TXT, no console",
            "contacts": "disabled (flag contact=disable, no geoms)",
            "inertia": f"explicit <inertial>: scene mass, diaginertia {POINT_INERTIA:g} "
                       "(point mass; scene radius/inertia unused, as in refsim's particles)",
            "fluid": "density 0, viscosity 0, wind 0",
            "drag": "joint damping: b per slide (added to c on a spring slide), b L^2 per "
                    "hinge: exact f = -b v for a point mass",
            "armature": 0.0, "frictionloss": 0.0, "joint_limits": "none",
            "energy_flag": "off (refsim computes energy from x, v)",
            "bodies": [p.describe() for p in self.plans],
            "step_call": "mj_step(model, data, nstep=n): one Python call per step(n), the loop "
                         "in C; swapping the warning callback and reading the warning counters "
                         "add about 2.5 us per step(n) call (not per step; measured on a 2-core "
                         "x86-64)",
            "version": self.mj.__version__,
        }

    def close(self):
        self.model = self.data = None
