"""MuJoCo's pivoted rigid bodies: scenes holding `RigidBodies` and `RigidPivots` (+ gravity).

Each pivoted body is one MuJoCo body whose frame sits at the pivot (the world anchor) with the
identity as reference orientation, holding one `ball` joint at its origin. Its `<inertial>` is
placed at the centre of mass, -body_point in that frame, with the scene's mass and the scene's
body-frame tensor as principal moments (`diaginertia`) and axes (the inertial `quat`, eigh). The
ball joint's qpos is then exactly the scene's orientation quaternion (w, x, y, z), body to world,
and its qvel the BODY-frame angular velocity: the scene's world w is rotated into it at build
(R^T w) and back when observed (R w). Observed x = anchor - R body_point, v = w x (x - anchor):
the joint is exact (generalized coordinates), so the extra observable `pivot_gap` (k,) m,
|x + R body_point - anchor| per pivot, is round-off.

Facts (mujoco 4.0.0, measured in tests/engines/mujoco/test_mujoco_pivots.py; in settings()):
- the ball joint's quaternion is moved by the exponential map of the body-frame angular velocity
  and normalised after every position update (mj_integratePos), so orientation_defect stays at
  round-off: the normalisation hides any drift of the update itself;
- an inertia whose principal moments violate A + B >= C is refused by MuJoCo's compiler: refused
  here with the reason (balanceinertia would change the body);
- Euler (symplectic_euler) is the kick-drift step with the gyroscopic and gravity torques
  explicit; RK4 is fourth order; implicit solves the velocity derivative of the bias force
  (gyroscopic) implicitly, which damps the motion (heavy top, 2 s at 1 ms: E -0.45 J of 7.19
  where Euler gains +0.49 J); implicitfast skips that derivative on a ball joint and takes
  exactly Euler's step (measured equal to the last digit): reported, never corrected.
Bodies without a pivot in a pivoted scene are refused (this group models pivoted bodies only).
"""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from refsim.engine import ModelGroup
from refsim.scene import RigidBodies
from refsim.scene.pivots import RigidPivots, check_on_anchor

from ..methods import METHODS
from ..mjcf import xml_floats
from ..sim import BAD_WARNINGS, MujocoSim
from ..spheres import rotate
from .rigid_sim import (INERTIA_RTOL, PARTICLE_SETTINGS, check_compiled_bodies, conjugate,
                        engine_energy, principal_frame)

WHO = "mujoco adapter"
PIVOT_INTEGRATORS = ("symplectic_euler", "rk4", "implicit", "implicitfast")
TREATED_IMPLICITLY = {
    "symplectic_euler": "nothing (velocity first, then the orientation with the new velocity)",
    "rk4": "nothing (explicit)",
    "implicit": "the velocity derivative of the bias force (gyroscopic w x I w of the ball "
                "joint), linearised backward Euler on w",
    "implicitfast": "nothing here: it skips the RNE (Coriolis/gyroscopic) derivatives, and a "
                    "ball joint has no damping; measured equal to symplectic_euler to the last "
                    "digit on the heavy top (energy gained, not damped)",
}
_NOTES = {
    "symplectic_euler": "semi-implicit Euler on the ball joint: w_body += h M^-1 (tau_g - "
                        "w x I w) from the state at k, then q <- q exp(h w_body / 2), "
                        "normalised",
    "rk4": "classical 4-stage Runge-Kutta on (qpos, qvel), stage quaternions moved by the "
           "exponential map",
    "implicit": "implicit-in-velocity Euler: (M - h dc/dv) dv = h (tau - c), positions explicit",
    "implicitfast": "implicit-in-velocity Euler without the RNE derivatives (symmetric part "
                    "only)",
}


# -- the group ----------------------------------------------------------------------------------
def claims(scene) -> bool:
    return scene.part(RigidBodies) is not None and scene.part(RigidPivots) is not None


def pivot_refusal(scene) -> str | None:
    """Why this group cannot take the scene's pivots (unpivoted bodies, A + B < C), or None."""
    pivots, rigid = scene.part(RigidPivots), scene.part(RigidBodies)
    try:
        check_on_anchor(pivots, rigid)
    except ValueError as exc:
        return f"{WHO}: {exc}"
    if len(pivots) != len(rigid):
        return (f"{WHO}: every rigid body of a pivoted scene must have a pivot (bodies "
                f"{sorted(set(range(len(rigid))) - set(pivots.body.tolist()))} have none); free "
                f"bodies beside pivoted ones are not modelled by this group")
    for i, tensor in enumerate(rigid.inertia):
        a, b, c = np.sort(principal_frame(tensor)[0])
        if a + b < c:
            return (f"{WHO}: rigid body {i} has principal moments {a!r}, {b!r}, {c!r} with "
                    f"A + B < C, which MuJoCo refuses as non-physical (balancing it would "
                    f"change the body)")
    return None


def supports(engine, scene, integrator):
    return pivot_refusal(scene)


def pivot_methods() -> dict:
    """The engine's Method records with pivoted-body notes (not symplectic on rotation)."""
    return {name: replace(METHODS[name], symplectic=False, note=_NOTES[name])
            for name in PIVOT_INTEGRATORS}


def build(engine, scene, dt, integrator, formulation):
    if integrator not in PIVOT_INTEGRATORS:
        raise ValueError(f"mujoco pivot integrator must be one of {list(PIVOT_INTEGRATORS)}, "
                         f"got {integrator!r}")
    return MujocoPivotSim(scene, dt, integrator, pivot_methods()[integrator])


MODEL_GROUP = ModelGroup(
    name="pivots", build=build, claims=claims, parts=frozenset({"rigid", "rigid_pivots"}),
    features=frozenset({"rigid", "pivots", "gravity"}), supports=supports,
    formulations=lambda engine, scene: ("",), integrators=PIVOT_INTEGRATORS)


# -- MJCF -------------------------------------------------------------------------------------
def _body_xml(index, mass, inertia, body_point, anchor, mj) -> str:
    """Body frame at the anchor (reference orientation identity), ball joint at its origin,
    inertial at the COM (-body_point) with the principal moments and axes."""
    moments, axes = principal_frame(inertia)
    iquat = np.zeros(4)
    mj.mju_mat2Quat(iquat, np.ascontiguousarray(axes).ravel())
    return (f'<body name="p{index}" pos="{xml_floats(anchor)}">'
            f'<inertial pos="{xml_floats(-body_point)}" quat="{xml_floats(iquat)}" '
            f'mass="{xml_floats(mass)}" diaginertia="{xml_floats(moments)}"/>'
            f'<joint name="p{index}_ball" type="ball" pos="0 0 0" damping="0" armature="0" '
            f'frictionloss="0"/></body>')


def pivot_scene_xml(scene, dt, method, mj) -> str:
    """MJCF: explicit timestep and gravity, no fluid forces, contacts/eulerdamp/autoreset off."""
    r, pv = scene.part(RigidBodies), scene.part(RigidPivots)
    bodies = "".join(_body_xml(i, r.mass[b], r.inertia[b], pv.body_point[i], pv.anchor[i], mj)
                     for i, b in enumerate(pv.body))  # build time only
    return (f'<mujoco model="refsim_pivots"><compiler inertiafromgeom="false" '
            f'balanceinertia="false"/>'
            f'<option timestep="{xml_floats(dt)}" gravity="{xml_floats(scene.gravity)}" '
            f'integrator="{method.xml}" density="0" viscosity="0" wind="0 0 0">'
            f'<flag contact="disable" eulerdamp="disable" autoreset="disable"/></option>'
            f'<worldbody>{bodies}</worldbody></mujoco>')


class MujocoPivotSim(MujocoSim):
    """Ball-jointed bodies: qpos (k, 4) = scene orientation, qvel (k, 3) = body-frame w."""

    def __init__(self, scene, dt, integrator, method):
        import mujoco
        self.mj, self.scene, self.dt = mujoco, scene, dt
        self.integrator, self.method = integrator, method
        self.plans, self.spheres, self.contact = [], False, None
        self.steps, self.failure, self._messages = 0, None, []
        self.pivots = scene.part(RigidPivots)
        self.order = self.pivots.body  # pivot i drives scene body order[i]
        self.k = len(self.pivots)
        t0 = time.perf_counter()
        self.model = mujoco.MjModel.from_xml_string(pivot_scene_xml(scene, dt, method, mujoco))
        self.compile_s = time.perf_counter() - t0
        self._check_model()
        self._check_inertia()
        self.data = mujoco.MjData(self.model)
        self._set_initial_state()
        self._bad = np.array([int(getattr(mujoco.mjtWarning, w)) for w in BAD_WARNINGS])
        self._counts = self.data.warning.number

    def _set_initial_state(self):
        r = self.scene.part(RigidBodies)
        q0 = r.orientation[self.order]
        self.data.qpos[:] = q0.ravel()
        self.data.qvel[:] = rotate(conjugate(q0), r.angular_velocity[self.order]).ravel()

    def _check_inertia(self):
        r = self.scene.part(RigidBodies)
        check_compiled_bodies(self.model, self.mj, r.mass[self.order], r.inertia[self.order],
                              -self.pivots.body_point)

    # -- observation --------------------------------------------------------------------------
    def _observe(self):
        """x = anchor - R p, v = w x (x - anchor), q = qpos as stored, w = R w_body (world),
        orientation_defect = |q|^2 - 1, pivot_gap (k,) = |x - R(-p) - anchor| per pivot (round-off:
        exact joint),
        engine_energy = MuJoCo's kinetic + potential energy (mj_forward, mj_energyPos/Vel)."""
        n = len(self.scene.part(RigidBodies))
        q = self.data.qpos.reshape(self.k, 4).copy()
        w_body = self.data.qvel.reshape(self.k, 3)
        arm = -rotate(q, self.pivots.body_point)  # anchor -> centre of mass
        w = rotate(q, w_body)
        out = {"x": np.zeros((n, 3)), "v": np.zeros((n, 3)), "q": np.zeros((n, 4)),
               "w": np.zeros((n, 3))}
        for name, value in (("x", self.pivots.anchor + arm), ("v", np.cross(w, arm)),
                            ("q", q), ("w", w)):
            out[name][self.order] = value
        out["orientation_defect"] = np.zeros(n)
        out["orientation_defect"][self.order] = np.einsum("ni,ni->n", q, q) - 1.0
        out["pivot_gap"] = np.linalg.norm(out["x"][self.order] - arm - self.pivots.anchor,
                                          axis=1)
        out["engine_energy"] = self._engine_energy()
        return out

    def _engine_energy(self) -> float:
        return engine_energy(self.mj, self.model, self.data)

    # -- settings -----------------------------------------------------------------------------
    def settings(self):
        out = self._base_settings()
        for key in PARTICLE_SETTINGS:
            out.pop(key, None)
        out["integrator"]["implicit"] = not self.method.explicit
        out["integrator"]["treated_implicitly"] = TREATED_IMPLICITLY[self.integrator]
        out.update(self._pivot_settings())
        return out

    def _pivot_settings(self) -> dict:
        return {
            "formulation": "one body per pivot, frame at the anchor, one ball joint at its "
                           "origin: qpos = the scene's orientation quaternion (w x y z), qvel "
                           "= body-frame angular velocity (generalized coordinates: the pivot "
                           "holds exactly)",
            "bodies": self.k,
            "pivots": {"body": self.pivots.body.tolist(),
                       "body_point": self.pivots.body_point.tolist(),
                       "anchor": self.pivots.anchor.tolist()},
            "inertia": "explicit <inertial> at the COM (pos = -body_point): scene mass, "
                       "principal moments (diaginertia) and axes (inertial quat) of the "
                       f"scene's body-frame tensor; compiled tensor checked to "
                       f"{INERTIA_RTOL:g} relative; inertiafromgeom=false, balanceinertia="
                       "false; A + B < C refused",
            "angular_velocity_frame": "scene w (world) rotated into the ball joint's body "
                                      "frame at build (R^T w), back when observed (R w)",
            "quaternion": "ball joint quaternion moved by the exponential map of the body-frame "
                          "w and normalised after every position update (mj_integratePos): "
                          "orientation_defect stays at round-off, hiding any drift",
            "gyroscopic": "bias force w x I_p w (about the pivot) from MuJoCo's RNE: explicit "
                          "in symplectic_euler and rk4; its velocity derivative implicit in "
                          "implicit (and where computed, implicitfast)",
            "contacts": "disabled (flag contact=disable, no geoms)",
            "eulerdamp": "disabled (nothing is damped: joint damping 0)",
            "damping": "none: ball joints with damping 0, armature 0, frictionloss 0",
            "velocity_limits": "none (MuJoCo clamps no velocities)",
            "energy_flag": "off while stepping; engine_energy read at observe() by mj_forward "
                           "+ mj_energyPos + mj_energyVel (potential -m g.x)",
        }
