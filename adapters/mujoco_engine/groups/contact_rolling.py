"""MuJoCo's rolling group: rigid bodies with collision shapes (`RigidShapes`) on walls, with
friction (a `ContactModel`): a disc or sphere rolling or slipping on an incline.

Module named so that it sorts before `rigid` (discover_groups takes the first group that claims
a scene; `rigid` claims every rigid scene). Each rigid body is a free-jointed MuJoCo body at its
centre of mass with an explicit `<inertial>` (scene mass, principal moments and axes; inertia
never from the geoms) and one geom: a sphere, or a cylinder whose axis (MuJoCo's geom z) is
turned onto body y. Each wall is a plane geom through its point, z axis = its inward normal.
Contacts are listed as explicit shape-wall `<pair>`s (automatic contacts off) carrying:
- condim 3 (normal + two sliding frictions), friction mu on the pair (a pair's friction
  replaces the geoms' own, so no max/product rule enters), rolling and torsional friction 0,
  elliptic cone, impratio 1, Newton solver to 1e-10;
- solref in the direct form (-K, -B): a contact's relative normal acceleration is held at
  aref = -K pos - B vel, K = (pi / T_c)^2 with T_c = CONTACT_STEPS dt (the sphere adapter's
  contact duration), B = 2 sqrt(K) (critical damping: restitution 0; no impact happens here,
  the body starts touching at rest); the friction rows use the same solref (solreffriction 0:
  MuJoCo's rule), i.e. a tangential slip velocity is damped at rate B;
- solimp flat at d = 0.9999 (mjMAXIMP): the solver returns a = d aref + (1 - d) a0, so the
  contact acts as a near-hard constraint on acceleration: released touching with pos = 0 and
  vel = 0, the contact holds the body at once (no sinking phase in which friction, bounded by
  the growing normal force, would let it slip); a steady penetration (1 - d) g cos / (d K) and
  a creep slip (1 - d) a0_t / (d B) remain (1e-8 m, 2e-6 m/s at dt = 1 ms), far below the
  split-step error a t h / 2.
Integrators: symplectic_euler (MuJoCo's Euler) and rk4 (contacts re-detected and re-solved at
each stage). Observables: x, v, q (w, x, y, z), w (world), orientation_defect (|q|^2 - 1).
"""
from __future__ import annotations

import time

import numpy as np

from refsim.engine import ModelGroup
from refsim.scene import RigidBodies, Walls
from refsim.scene.rigid_shapes import RigidShapes, rolling_scene_refusal

from ..contact_params import SOLVER_ITERATIONS, SOLVER_TOLERANCE
from ..mjcf import xml_floats
from ..sim import BAD_WARNINGS, MujocoSim
from ..spheres import rotate
from .rigid import principal_frame, rigid_methods
from .rigid_sim import conjugate

WHO = "mujoco adapter"
ROLLING_INTEGRATORS = ("symplectic_euler", "rk4")
CONTACT_STEPS = 10  # T_c = 10 dt: the sphere adapter's contact duration (contact_params)
IMPEDANCE = 0.9999  # mjMAXIMP: a near-hard contact (see the module docstring)
CONTACT_MARGIN = 1e-9  # m: MuJoCo excludes a contact at dist = margin - gap (exactly touching);
# a body released touching would fall freely for one step (g cos h^2 deep) and the soft contact
# would then push it out, hopping off a slipping disc (measured: 0.7 mm, contact lost). With
# this margin the contact acts from step 1, pos = dist - margin: the body rides 1e-9 m higher
_NOTES = {
    "symplectic_euler": "semi-implicit Euler: v, w += h M^-1 (f + contact), contact forces "
                        "from the constraint solve at the state at k; then x += h v, q by the "
                        "exponential map of h w, normalised",
    "rk4": "classical 4-stage Runge-Kutta on (qpos, qvel); contacts re-detected and the "
           "constraint problem re-solved at each stage",
}


def claims(scene) -> bool:
    return scene.part(RigidBodies) is not None and scene.part(RigidShapes) is not None


def supports(engine, scene, integrator):
    reason = rolling_scene_refusal(scene, WHO)
    if reason:
        return reason
    for i, tensor in enumerate(scene.part(RigidBodies).inertia):
        a, b, c = np.sort(principal_frame(tensor)[0])
        if a + b < c:
            return (f"{WHO}: rigid body {i} has principal moments with A + B < C, which "
                    f"MuJoCo refuses as non-physical")
    return None


def build(engine, scene, dt, integrator, formulation):
    if integrator not in ROLLING_INTEGRATORS:
        raise ValueError(f"mujoco rolling integrator must be one of "
                         f"{list(ROLLING_INTEGRATORS)}, got {integrator!r}")
    return MujocoRollingSim(scene, dt, integrator)


MODEL_GROUP = ModelGroup(
    name="rolling", build=build, claims=claims,
    parts=frozenset({"rigid", "rigid_shapes", "walls"}),
    features=frozenset({"rigid", "shapes", "walls", "contacts", "gravity"}), supports=supports,
    formulations=lambda engine, scene: ("",), integrators=ROLLING_INTEGRATORS)


# -- MJCF -------------------------------------------------------------------------------------
def contact_constants(dt: float) -> tuple[float, float]:
    """(K, B): stiffness (1/s^2) of a T_c = CONTACT_STEPS dt contact, critical damping."""
    stiffness = (np.pi / (CONTACT_STEPS * dt)) ** 2
    return float(stiffness), float(2.0 * np.sqrt(stiffness))


def _geom_xml(index, shape, radius, half_length) -> str:
    if shape == "sphere":
        return f'<geom name="g{index}" type="sphere" size="{xml_floats(radius)}"/>'
    return (f'<geom name="g{index}" type="cylinder" zaxis="0 1 0" '
            f'size="{xml_floats([radius, half_length])}"/>')


def _body_xml(scene, index, mj) -> str:
    r, shapes = scene.part(RigidBodies), scene.part(RigidShapes)
    j = int(np.flatnonzero(shapes.body == index)[0])
    moments, axes = principal_frame(r.inertia[index])
    iquat = np.zeros(4)
    mj.mju_mat2Quat(iquat, np.ascontiguousarray(axes).ravel())
    return (f'<body name="r{index}" pos="{xml_floats(r.position[index])}" '
            f'quat="{xml_floats(r.orientation[index])}"><inertial pos="0 0 0" '
            f'quat="{xml_floats(iquat)}" mass="{xml_floats(r.mass[index])}" '
            f'diaginertia="{xml_floats(moments)}"/><freejoint name="r{index}_free"/>'
            f'{_geom_xml(index, shapes.shape[j], shapes.radius[j], shapes.half_length[j])}'
            f'</body>')


def _pairs_xml(scene, dt) -> str:
    stiffness, damping = contact_constants(dt)
    mu = xml_floats(scene.contact.friction)
    attrs = (f'condim="3" friction="{mu} {mu} 0 0 0" solref="{xml_floats(-stiffness)} '
             f'{xml_floats(-damping)}" solimp="{IMPEDANCE!r} {IMPEDANCE!r} 0.001 0.5 2" '
             f'margin="{xml_floats(CONTACT_MARGIN)}" gap="0"')
    return "".join(f'<pair geom1="w{k}" geom2="g{b}" {attrs}/>'
                   for k in range(len(scene.part(Walls))) for b in scene.part(RigidShapes).body)


def rolling_scene_xml(scene, dt, method, mj) -> str:
    walls = "".join(f'<geom name="w{k}" type="plane" pos="{xml_floats(p)}" '
                    f'zaxis="{xml_floats(n)}" size="0 0 1"/>'
                    for k, (p, n) in enumerate(zip(scene.part(Walls).point,
                                                     scene.part(Walls).normal)))
    bodies = "".join(_body_xml(scene, i, mj) for i in range(len(scene.part(RigidBodies))))
    return (f'<mujoco model="refsim_rolling"><compiler inertiafromgeom="false" '
            f'balanceinertia="false"/>'
            f'<option timestep="{xml_floats(dt)}" gravity="{xml_floats(scene.gravity)}" '
            f'integrator="{method.xml}" density="0" viscosity="0" wind="0 0 0" '
            f'cone="elliptic" solver="Newton" iterations="{SOLVER_ITERATIONS}" '
            f'tolerance="{SOLVER_TOLERANCE}" impratio="1" noslip_iterations="0">'
            f'<flag eulerdamp="disable" autoreset="disable"/></option>'
            f'<default><geom contype="0" conaffinity="0" friction="0 0 0"/></default>'
            f'<worldbody>{walls}{bodies}</worldbody><contact>{_pairs_xml(scene, dt)}'
            f'</contact></mujoco>')


class MujocoRollingSim(MujocoSim):
    """Free bodies with one geom each, explicit shape-wall contact pairs."""

    def __init__(self, scene, dt, integrator):
        import mujoco
        self.mj, self.scene, self.dt = mujoco, scene, dt
        self.integrator, self.method = integrator, rigid_methods()[integrator]
        self.method = type(self.method)(**{**self.method.__dict__,
                                           "note": _NOTES[integrator]})
        self.plans, self.spheres, self.contact = [], False, None
        self.steps, self.failure, self._messages = 0, None, []
        self.n = len(scene.part(RigidBodies))
        t0 = time.perf_counter()
        self.model = mujoco.MjModel.from_xml_string(
            rolling_scene_xml(scene, dt, self.method, mujoco))
        self.compile_s = time.perf_counter() - t0
        self._check_compiled()
        self.data = mujoco.MjData(self.model)
        r = scene.part(RigidBodies)
        qvel = np.concatenate([r.velocity, rotate(conjugate(r.orientation),
                                                  r.angular_velocity)], axis=1)
        self.data.qvel[:] = qvel.ravel()
        self._bad = np.array([int(getattr(mujoco.mjtWarning, w)) for w in BAD_WARNINGS])
        self._counts = self.data.warning.number

    def _check_compiled(self):
        """Options and masses as asked (MuJoCo's defaults differ)."""
        m, mj, r = self.model, self.mj, self.scene.part(RigidBodies)
        off = m.opt.disableflags
        wanted = int(getattr(mj.mjtIntegrator, self.method.native))
        if (m.opt.timestep != self.dt or not np.array_equal(m.opt.gravity, self.scene.gravity)
                or m.opt.integrator != wanted
                or off & int(mj.mjtDisableBit.mjDSBL_CONTACT)
                or not off & int(mj.mjtDisableBit.mjDSBL_EULERDAMP)
                or not np.array_equal(m.body_mass[1:self.n + 1], r.mass)):
            raise RuntimeError("mujoco compiled other options or masses than the adapter "
                               "asked for")

    def _observe(self):
        """Free joints: qpos = (centre, quaternion), qvel = (v world, w body frame)."""
        q, qd = self.data.qpos.reshape(self.n, 7), self.data.qvel.reshape(self.n, 6)
        quat = q[:, 3:].copy()
        return {"x": q[:, :3].copy(), "v": qd[:, :3].copy(), "q": quat,
                "w": rotate(quat, qd[:, 3:]),
                "orientation_defect": np.einsum("ni,ni->n", quat, quat) - 1.0}

    def settings(self):
        out = self._base_settings()
        for key in ("drag", "bodies", "armature", "frictionloss", "joint_limits", "inertia"):
            out.pop(key, None)
        stiffness, damping = contact_constants(self.dt)
        out.update({
            "formulation": "free joint per body; sphere or cylinder geom (axis body y); plane "
                           "geom per wall; explicit shape-wall <pair>s",
            "contact_model": "soft", "contact_duration_s": CONTACT_STEPS * self.dt,
            "contact_steps": CONTACT_STEPS, "solref": [-stiffness, -damping],
            "solref_form": "direct (-K, -B): aref = -K pos - B vel; B = 2 sqrt(K) (critical, "
                           "restitution 0)",
            "solreffriction": "0 0 (friction rows use solref: slip damped at rate B)",
            "solimp": [IMPEDANCE, IMPEDANCE, 0.001, 0.5, 2.0],
            "solimp_note": "flat d = 0.9999: a = d aref + (1 - d) a0, a near-hard contact",
            "contact_sink_factor": (1.0 - IMPEDANCE) / IMPEDANCE,
            "contact_soft_friction": True,
            "condim": 3, "cone": "elliptic", "impratio": 1.0, "noslip_iterations": 0,
            "friction": self.scene.contact.friction,
            "friction_mapping": "mu on every pair (replaces the geoms' friction), sliding "
                                "both directions; torsional and rolling 0",
            "restitution": "0 by critical damping (no impact: released touching at rest)",
            "margin": 0.0, "gap": 0.0,
            "solver": {"name": "Newton", "iterations": SOLVER_ITERATIONS,
                       "tolerance": SOLVER_TOLERANCE},
            "inertia": "explicit <inertial>: scene mass, principal moments and axes; "
                       "inertiafromgeom=false",
            "contacts": "enabled: shape-wall pairs only",
        })
        return out
