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

Sphere scenes (features "contacts", "walls"): one free-jointed body per sphere with an
explicit `<inertial>` (scene mass, diaginertia = the scene's 2/5 m r^2; `inertiafromgeom` off,
checked after compiling) and a sphere geom; each wall is a plane geom through its point with z
axis = its inward normal. MuJoCo has no restitution parameter (ENGINE_NOTES: the default solref
gives e ~ 0.13 whatever is asked), so contacts are its soft contacts in the direct form
solref = (-K, -B) with a flat impedance d (solimp dmin = dmax):
- an isolated contact's relative normal acceleration is then exactly -K pos - B vel, whatever
  the masses and d (engine_core_constraint.c stores K/d^2 and B/d, aref = -(B vel + K pos)/d,
  and the solver returns a = d aref when R = (1-d)/d A); K = (pi / (N dt))^2 makes an
  undamped contact last N = CONTACT_STEPS steps at every dt;
- B is calibrated in code: a bisection on B so that the restitution MuJoCo itself produces
  (two spheres head-on at the scene's dt with the scene's integrator), averaged over 32
  contact onsets within a step, equals e; the largest deviation over onsets is reported as
  the residual (cached per process);
- d decides how simultaneous contacts couple (engine variants): "" d = 1e-4, one linear
  spring-dashpot per contact (DEM); "coupled" d = 0.9999, MuJoCo's constraint regime;
- friction mu > 0: condim 3, elliptic cone; the friction rows' damping comes from
  `solreffriction`, which only explicit <pair> elements carry, so frictional scenes list every
  sphere-sphere and sphere-wall pair (at most MAX_FRICTION_SPHERES spheres);
- integrators: Euler, implicit and implicitfast take the same step here; RK4 re-detects and
  re-solves contacts at each stage; discrete (backward Euler on the contact spring) is refused.
"""
from __future__ import annotations

import functools
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

_BAD_WARNINGS = ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC", "mjWARN_INERTIA",
                 "mjWARN_CONTACTFULL", "mjWARN_CNSTRFULL")  # full buffers drop contacts

# -- sphere contacts (mujoco 4.0.0) -----------------------------------------------------------
CONTACT_STEPS = 10  # an undamped contact lasts this many steps: K = (pi / (N dt))^2. Shorter
# contacts spread e over the contact phase (+-8.7 % at 3 steps, +-0.2 % at 10: cubic in 1/N);
# longer ones turn the normal of an oblique impact during the contact (4.6 % of v at 10 steps
# of 1 ms, linear in N dt): 10 steps balances the two (MuJoCo's own default is solref
# timeconst 0.02 s at its 0.002 s step, also 10 steps)

# Flat impedance d (solimp dmin = dmax) per engine variant. An isolated contact is the same
# at any d; simultaneous contacts and resting ones are not: the solver returns
# f = (A + R)^-1 (aref - a0), R = (1 - d)/d diag(A), aref = -(B vel + K pos)/d.
IMPEDANCE = {
    # d = mjMINIMP: R = 1e4 A dominates, f_k = -(K pos_k + B vel_k) / A_kk to 1e-4: a linear
    # spring-dashpot per contact with the pair's reduced mass (the DEM soft-sphere model).
    # Measured: the cradle keeps its energy (+1 %), a ball rests on a floor at g/K overlap
    "": 1e-4,
    # d = mjMAXIMP: R = 1e-4 A, all contacts solved as one coupled system, each one's relative
    # acceleration held at -K pos - B vel while (1 - d) of the external acceleration passes:
    # resting contacts transmit force at once (the cradle's chain acts as one block, +13 %
    # energy) and a ball on a floor under gravity chatters (overlap (1-d) g/K << g dt^2)
    "coupled": 0.9999,
}
VARIANT_NOTES = {
    "": "solimp flat at d = 1e-4 (mjMINIMP): R = 1e4 A dominates the solve, so each contact "
        "force is mu_k (K pos + B vel), mu_k the pair's reduced mass (1/A_kk), independent of "
        "the other contacts to 1e-4: the linear spring-dashpot (DEM) model",
    "coupled": "solimp flat at d = 0.9999 (mjMAXIMP): the contacts are solved as one coupled "
               "system, each contact's relative normal acceleration held at -K pos - B vel; "
               "resting contacts transmit force at once (a chain acts as a near-rigid block); "
               "isolated impacts are identical to the default variant",
}

CALIBRATION_PHASES = 32  # contact onsets at (k + 1/2)/32 of a step: the mean of e
EDGE_PHASES = (1e-9, 1.0 - 1e-9)  # e(phase) peaks at the ends: the residual includes them
SOLVER_TOLERANCE = 1e-10  # Newton solver (MuJoCo default 1e-8)
SOLVER_ITERATIONS = 100  # MuJoCo default; a lone contact converges in 1-2 Newton iterations
MAX_FRICTION_SPHERES = 200  # frictional scenes list every pair explicitly (O(n^2) pairs)
CONTACT_METHODS = ("symplectic_euler", "implicit", "implicitfast", "rk4")


# ---------------------------------------------------------------------------------------------
# Scene -> per-body joint plan (also the single source of `supports` reasons)
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BodyPlan:
    kind: str  # "particle", "spring", "hinge" or "sphere"
    index: int
    mass: float
    position: tuple
    axis: tuple = (0.0, 0.0, 0.0)  # slide axis (spring) or hinge axis
    joint_pos: tuple = (0.0, 0.0, 0.0)  # hinge point in the body frame
    stiffness: float = 0.0
    springref: float = 0.0
    damping: float = 0.0
    qvel0: tuple = ()
    radius: float = 0.0  # sphere
    inertia: float = 0.0  # sphere: scalar moment about the centre

    def describe(self) -> dict:
        text = {"particle": "3 slide joints (x, y, z): exact point-mass translation",
                "spring": "1 slide joint along the anchor-body line, joint stiffness/springref",
                "hinge": "1 hinge joint through the anchor: generalized coordinate",
                "sphere": "free joint, sphere geom, explicit inertial"}[self.kind]
        if self.kind == "sphere":
            return {"body": self.index, "formulation": text, "radius": self.radius,
                    "mass": self.mass, "inertia": self.inertia}
        return {"body": self.index, "formulation": text, "axis": list(self.axis),
                "stiffness": self.stiffness, "springref": self.springref,
                "joint_damping": self.damping}


def plan_scene(scene) -> list[BodyPlan]:
    """One plan per body; ValueError with a one-sentence reason when it cannot be faithful."""
    if scene.contact is not None or scene.walls:
        return _sphere_plans(scene)
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


def _sphere_plans(scene) -> list[BodyPlan]:
    """Every body a free sphere; qvel0 = (v, w): the free joint's angular velocity is in the
    body frame, which is the world frame at t = 0 (identity orientation)."""
    if scene.contact is None:
        raise ValueError("mujoco adapter: walls need a contact model (scene.contact)")
    if scene.springs or scene.joints:
        raise ValueError("mujoco adapter: springs and rods are not combined with contacts "
                         "(every sphere is a free body)")
    if scene.linear_drag > 0:
        raise ValueError("mujoco adapter: linear drag on spheres is not modelled (damping on a "
                         "free joint would also damp the spin)")
    if any(b.radius <= 0 for b in scene.bodies):
        raise ValueError("mujoco adapter: contacts need spheres (radius > 0)")
    if any(b.inertia <= 0 for b in scene.bodies):
        raise ValueError("mujoco adapter: a sphere needs its moment of inertia (> 0); the "
                         "adapter never lets MuJoCo derive one from the geom")
    if scene.contact.friction > 0 and len(scene.bodies) > MAX_FRICTION_SPHERES:
        raise ValueError(f"mujoco adapter: friction is modelled for at most "
                         f"{MAX_FRICTION_SPHERES} spheres (its damping, solreffriction, is "
                         f"set only on explicit contact pairs, O(n^2) of them)")
    return [BodyPlan("sphere", i, b.mass, b.position, radius=b.radius, inertia=b.inertia,
                     qvel0=b.velocity + b.angular_velocity)
            for i, b in enumerate(scene.bodies)]


# ---------------------------------------------------------------------------------------------
# Contacts: stiffness, restitution calibration, friction damping
# ---------------------------------------------------------------------------------------------
def contact_stiffness(dt: float) -> float:
    """K (1/s^2, relative normal acceleration per metre of overlap): an undamped contact is
    half a period of w = sqrt(K), i.e. CONTACT_STEPS steps."""
    return (math.pi / (CONTACT_STEPS * dt)) ** 2


def friction_damping(dt: float) -> float:
    """Bf (1/s) of the friction rows (solreffriction, direct form): critical damping at the
    contact frequency, 2 sqrt(K), as MuJoCo's default dampratio 1 gives its friction rows."""
    return 2.0 * math.sqrt(contact_stiffness(dt))


@dataclass(frozen=True)
class RestitutionMap:
    """Damping B giving the requested e at one dt and integrator, measured in MuJoCo."""

    restitution: float
    dt: float
    integrator: str
    stiffness: float
    damping: float
    e_mean: float  # mean over the contact phases at `damping`
    residual: float  # max |e(phase) - e| at `damping`, edge phases included
    e_phases: tuple  # at the CALIBRATION_PHASES midpoints
    clamped: bool  # e outside (e(B = 1/dt), e(B = 0)): B is held at that bound

    def describe(self) -> dict:
        return {
            "method": "direct solref (-K, -B); B found by bisection so that the restitution "
                      "measured in MuJoCo (two unit spheres head-on, relative speed 2 m/s, "
                      f"condim 1, this dt and integrator), averaged over {CALIBRATION_PHASES} "
                      "contact onsets spread evenly over a step, equals e; residual_max also "
                      "covers onsets just after and just before a step boundary",
            "e_requested": self.restitution, "K": self.stiffness, "B": self.damping,
            "damping_ratio": self.damping / (2.0 * math.sqrt(self.stiffness)),
            "B_dt": self.damping * self.dt,
            "e_mean": self.e_mean, "mean_error": self.e_mean - self.restitution,
            "residual_max": self.residual,
            "e_per_phase": list(self.e_phases), "clamped_at_bound": self.clamped,
            "note": "the spread over phases comes from where in the step a contact starts "
                    "(the first overlapping step already feels the whole spring and damper); "
                    "a given impact's e lies within residual_max of e. e = 1 sits at B = 0 "
                    "(no damping can add energy), e below e(B = 1/dt) ~ 0.05 at B = 1/dt",
        }


@functools.lru_cache(maxsize=None)
def restitution_map(e: float, dt: float, integrator: str, impedance: float) -> RestitutionMap:
    """Bisection on B in [0, 1/dt] (explicit damping: stable while B dt < 2); e(B) falls
    monotonically from ~1 (B = 0) to ~0.05 (B = 1/dt) at 10-step contacts. Deterministic;
    cached per process."""
    import mujoco
    k = contact_stiffness(dt)
    xml = _calibration_xml(dt, k, METHODS[integrator].xml, impedance)
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)

    mids = (np.arange(CALIBRATION_PHASES) + 0.5) / CALIBRATION_PHASES

    def mean_e(b):
        return float(np.mean(_phase_restitutions(mujoco, model, data, k, b, mids)))

    lo, hi = 0.0, 1.0 / dt
    e_lo, e_hi = mean_e(lo), mean_e(hi)
    if e >= e_lo or e <= e_hi:
        b = lo if e >= e_lo else hi
    else:
        for _ in range(40):  # B to 1e-12 of its range
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if mean_e(mid) > e else (lo, mid)
        b = 0.5 * (lo + hi)
    values = _phase_restitutions(mujoco, model, data, k, b, mids)
    edges = _phase_restitutions(mujoco, model, data, k, b, EDGE_PHASES)
    residual = float(np.max(np.abs(np.concatenate([values, edges]) - e)))
    return RestitutionMap(e, dt, integrator, k, b, float(np.mean(values)), residual,
                          tuple(float(v) for v in values), bool(e >= e_lo or e <= e_hi))


def _calibration_xml(dt, k, integrator_xml, impedance):
    r, inertia = 0.1, 0.004  # unit masses; the result depends on neither (acceleration space)
    sphere = (f'<freejoint/><inertial pos="0 0 0" mass="1" diaginertia="{inertia} {inertia} '
              f'{inertia}"/><geom type="sphere" size="{r}" condim="1" solref="{-k!r} -0" '
              f'solimp="{impedance!r} {impedance!r} 0.001 0.5 2"/>')
    return (f'<mujoco><compiler inertiafromgeom="false"/><option timestep="{dt!r}" '
            f'gravity="0 0 0" integrator="{integrator_xml}" tolerance="{SOLVER_TOLERANCE}">'
            f'<flag eulerdamp="disable" autoreset="disable"/></option><worldbody>'
            f'<body pos="-1 0 0">{sphere}</body><body pos="1 0 0">{sphere}</body>'
            f'</worldbody></mujoco>')


def _phase_restitutions(mj, model, data, k, b, phases) -> np.ndarray:
    """e = separation speed / approach speed (2 m/s) for contacts starting (2 + phase) steps
    in; run until well past the end of the contact."""
    dt = model.opt.timestep
    model.geom_solref[:] = (-k, -b)
    out = np.empty(len(phases))
    for i, phase in enumerate(phases):
        mj.mj_resetData(model, data)
        gap = 2.0 * dt * (2.0 + phase)
        data.qpos[0], data.qpos[7] = -0.1 - gap / 2, 0.1 + gap / 2
        data.qvel[0], data.qvel[6] = 1.0, -1.0
        mj.mj_step(model, data, nstep=4 * CONTACT_STEPS + 10)
        out[i] = (data.qvel[6] - data.qvel[0]) / 2.0
    return out


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
    elif plan.kind == "hinge":
        joints = (f'<joint name="b{plan.index}_hinge" type="hinge" pos="{_fmt(plan.joint_pos)}" '
                  f'axis="{_fmt(plan.axis)}" damping="{_fmt(plan.damping)}"/>')
    else:
        inertial = (f'<inertial pos="0 0 0" mass="{_fmt(plan.mass)}" '
                    f'diaginertia="{_fmt([plan.inertia] * 3)}"/>')
        joints = (f'<freejoint name="b{plan.index}_free"/>'
                  f'<geom name="s{plan.index}" type="sphere" size="{_fmt(plan.radius)}"/>')
    return f'<body name="b{plan.index}" pos="{_fmt(plan.position)}">{inertial}{joints}</body>'


def scene_xml(scene, plans, dt: float, method: Method, contact=None) -> str:
    """MJCF: explicit timestep and gravity, no fluid forces, eulerdamp/autoreset off; contacts
    off unless `contact` (a ContactSetup) describes them."""
    bodies = "".join(_body_xml(p) for p in plans)
    flags = 'eulerdamp="disable" autoreset="disable"'
    extra, default, walls, pairs = "", "", "", ""
    if contact is None:
        flags = 'contact="disable" ' + flags
    else:
        extra = (f' cone="elliptic" solver="Newton" iterations="{SOLVER_ITERATIONS}" '
                 f'tolerance="{SOLVER_TOLERANCE}" impratio="1"')
        default, walls, pairs = contact.default_xml(), contact.walls_xml(), contact.pairs_xml()
    return (f'<mujoco model="refsim"><compiler inertiafromgeom="false"/>'
            f'<option timestep="{_fmt(dt)}" gravity="{_fmt(scene.gravity)}" '
            f'integrator="{method.xml}" density="0" viscosity="0" wind="0 0 0"{extra}>'
            f'<flag {flags}/></option>{default}<worldbody>{walls}{bodies}</worldbody>'
            f'{pairs}</mujoco>')


@dataclass(frozen=True)
class ContactSetup:
    """Contact parameters of one sphere scene at one dt and integrator."""

    nbody: int
    walls: tuple  # ((point), (normal)) pairs
    restitution_map: RestitutionMap
    friction: float
    friction_damping: float
    variant: str

    @property
    def impedance(self) -> float:
        return IMPEDANCE[self.variant]

    @classmethod
    def make(cls, scene, dt, integrator, variant):
        rmap = restitution_map(scene.contact.restitution, dt, integrator, IMPEDANCE[variant])
        mu = scene.contact.friction
        return cls(len(scene.bodies), tuple((w.point, w.normal) for w in scene.walls), rmap,
                   mu, friction_damping(dt) if mu > 0 else 0.0, variant)

    @property
    def condim(self) -> int:
        return 3 if self.friction > 0 else 1

    def _params(self) -> str:
        k, b = self.restitution_map.stiffness, self.restitution_map.damping
        return (f'condim="{self.condim}" solref="{_fmt(-k)} {_fmt(-b)}" '
                f'solimp="{self.impedance!r} {self.impedance!r} 0.001 0.5 2" margin="0" '
                f'gap="0"')

    def default_xml(self) -> str:
        """Every geom: the contact parameters; frictional scenes switch automatic contacts off
        (contype = conaffinity = 0) and list their pairs instead."""
        if self.friction > 0:
            return ('<default><geom contype="0" conaffinity="0" friction="0 0 0"/></default>')
        return (f'<default><geom contype="1" conaffinity="1" friction="0 0 0" '
                f'{self._params()}/></default>')

    def walls_xml(self) -> str:
        return "".join(f'<geom name="w{k}" type="plane" pos="{_fmt(p)}" zaxis="{_fmt(n)}" '
                       f'size="0 0 1"/>' for k, (p, n) in enumerate(self.walls))

    def pairs_xml(self) -> str:
        if self.friction <= 0:
            return ""
        mu = _fmt(self.friction)
        attrs = (f'{self._params()} friction="{mu} {mu} 0 0 0" '
                 f'solreffriction="0 {_fmt(-self.friction_damping)}"')
        names = [f"s{i}" for i in range(self.nbody)]
        pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1:]]
        pairs += [(f"w{k}", a) for k in range(len(self.walls)) for a in names]
        return "<contact>" + "".join(f'<pair geom1="{a}" geom2="{b}" {attrs}/>'
                                     for a, b in pairs) + "</contact>"

    def describe(self, dt) -> dict:
        k = self.restitution_map.stiffness
        out = {
            "contact_model": "soft",
            "restitution_mapping": self.restitution_map.describe(),
            "solref": [-k, -self.restitution_map.damping],
            "solref_form": "direct (-stiffness, -damping): relative normal acceleration "
                           "-K pos - B vel for an isolated contact",
            "solimp": [self.impedance, self.impedance, 0.001, 0.5, 2.0],
            "solimp_note": "flat impedance (dmin = dmax, so width/midpoint/power are unused); "
                           "d cancels from an isolated contact and decides how simultaneous "
                           "contacts couple",
            "engine_variant": self.variant or "default",
            "simultaneous_contacts": VARIANT_NOTES[self.variant],
            "contact_steps": CONTACT_STEPS,
            "contact_duration_s": CONTACT_STEPS * dt,
            "contact_duration_note": "undamped half period pi / sqrt(K); damping shortens it",
            "condim": self.condim, "cone": "elliptic", "margin": 0.0, "gap": 0.0,
            "friction": self.friction,
            "solver": {"name": "Newton", "iterations": SOLVER_ITERATIONS,
                       "tolerance": SOLVER_TOLERANCE, "tolerance_default_replaced": 1e-8,
                       "noslip_iterations": 0, "impratio": 1.0},
            "ccd": "none: MuJoCo finds sphere-sphere and sphere-plane overlaps with analytic "
                   "primitives at the start of each step (no swept or continuous detection; "
                   "nativeccd/multiccd concern convex meshes only)",
            "walls": "plane geoms in the world body, z axis = inward normal (infinite for "
                     "collision)",
            "inertia": "explicit <inertial>: scene mass and diaginertia = scene inertia "
                       "(2/5 m r^2), inertiafromgeom=false, compiled values checked",
            "contacts": "enabled: sphere-sphere and sphere-wall",
        }
        if self.friction > 0:
            out["friction_model"] = (
                "condim 3, elliptic cone, mu on every explicit <pair> (sphere-sphere and "
                "sphere-wall; automatic contacts off); friction rows damped by solreffriction "
                f"(0, -Bf), Bf = 2 sqrt(K) = {self.friction_damping:.6g} 1/s: critical damping "
                "at the contact frequency (MuJoCo's default dampratio 1). MuJoCo's regularised "
                "cone couples sliding friction with the normal force: an impact that slides "
                "rebounds with less normal speed than Newton's law gives")
            out["friction_pairs"] = self.nbody * (self.nbody - 1) // 2 + self.nbody * len(
                self.walls)
        return out


# ---------------------------------------------------------------------------------------------
# Engine
# ---------------------------------------------------------------------------------------------
class MujocoEngine(Engine):
    name = "mujoco"
    package = "mujoco"
    capabilities = frozenset({"gravity", "springs", "joints", "drag", "contacts", "walls"})
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
        if scene.contact is not None and integrator is not None and \
                integrator not in CONTACT_METHODS:
            return ("mujoco discrete integrates the contact spring with backward Euler, which "
                    "dissipates: e = 0.65 measured at zero damping for a 10-step contact, so "
                    "larger e cannot be asked of it")
        return None

    def build(self, scene, dt, integrator, variant=""):
        if integrator not in METHODS:
            raise ValueError(f"mujoco integrator must be one of {list(METHODS)}, "
                             f"got {integrator!r}")
        if variant not in self.variants(scene):
            raise ValueError(f"mujoco variant must be one of {list(self.variants(scene))}, "
                             f"got {variant!r}")
        dt = float(dt)
        if not math.isfinite(dt) or dt <= 0:
            raise ValueError(f"dt must be a finite number > 0, got {dt}")
        reason = self.supports(scene, integrator)
        if reason:
            raise ValueError(reason)
        return MujocoSim(scene, plan_scene(scene), dt, integrator, variant)

    def variants(self, scene):
        """Sphere scenes: "" (spring-dashpot per contact, d = 1e-4) and "coupled" (MuJoCo's
        constraint regime, d = 0.9999)."""
        return tuple(IMPEDANCE) if scene.contact is not None else ("",)


class MujocoSim(Sim):
    def __init__(self, scene, plans, dt, integrator, variant=""):
        import mujoco
        self.mj, self.scene, self.plans, self.dt = mujoco, scene, plans, dt
        self.integrator, self.method = integrator, METHODS[integrator]
        self.steps, self.failure, self._messages = 0, None, []
        self.spheres = scene.contact is not None
        t0 = time.perf_counter()  # the restitution calibration (cached) counts as compilation
        self.contact = ContactSetup.make(scene, dt, integrator, variant) if self.spheres \
            else None
        xml = scene_xml(scene, plans, dt, self.method, self.contact)
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
        off = ["mjDSBL_EULERDAMP", "mjDSBL_AUTORESET"] + ([] if self.spheres else
                                                          ["mjDSBL_CONTACT"])
        flags = [int(getattr(mj.mjtDisableBit, f)) for f in off]
        contact_off = opt.disableflags & int(mj.mjtDisableBit.mjDSBL_CONTACT)
        if opt.timestep != self.dt or not np.array_equal(opt.gravity, self.scene.gravity) or \
                opt.integrator != wanted or not all(opt.disableflags & f for f in flags) or \
                (self.spheres and contact_off):
            raise RuntimeError("mujoco compiled other options than the adapter asked for")
        if self.spheres:
            self._check_spheres()

    def _check_spheres(self):
        """Masses and inertias are the scene's (MuJoCo never derived them from the geoms)."""
        m, n = self.model, len(self.plans)
        mass = np.array([p.mass for p in self.plans])
        inertia = np.repeat([[p.inertia] for p in self.plans], 3, axis=1)
        if not (np.array_equal(m.body_mass[1:n + 1], mass) and
                np.allclose(m.body_inertia[1:n + 1], inertia, rtol=1e-15, atol=0) and
                np.array_equal(m.body_ipos[1:n + 1], np.zeros((n, 3)))):
            raise RuntimeError("mujoco compiled other masses/inertias than the scene's")

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
        if self.spheres:
            return self._observe_spheres()
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

    def _observe_spheres(self):
        """Free joints: qpos = (centre, quaternion), qvel = (v world, w body frame)."""
        n = len(self.plans)
        q, qd = self.data.qpos.reshape(n, 7), self.data.qvel.reshape(n, 6)
        return {"t": self.steps * self.dt, "x": q[:, :3].copy(), "v": qd[:, :3].copy(),
                "w": rotate(q[:, 3:], qd[:, 3:])}

    def settings(self):
        out = self._base_settings()
        if self.spheres:
            out.update(self.contact.describe(self.dt))
            out["drag"] = "none (refused with contacts)"
            out["integrators_with_contacts"] = (
                "symplectic_euler (Euler), implicit and implicitfast take the same step here "
                "(no joint damping; a sphere's isotropic inertia has no gyroscopic term); rk4 "
                "re-detects contacts and re-solves at each stage (e = 1 within 1e-4 instead "
                "of 2e-3); discrete is refused (backward Euler on the contact spring)")
        return out

    def _base_settings(self):
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


def rotate(quat: np.ndarray, vec: np.ndarray) -> np.ndarray:
    """Rotate each vec (n, 3) by its unit quaternion (n, 4) = (w, x, y, z), MuJoCo's order."""
    w, u = quat[:, :1], quat[:, 1:]
    t = 2.0 * np.cross(u, vec)
    return vec + w * t + np.cross(u, t)
