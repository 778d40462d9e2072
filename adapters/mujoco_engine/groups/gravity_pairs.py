"""MuJoCo's n-body gravity: scenes whose parts are exactly `Particles` + `GravityPairs`.

MuJoCo has no pair forces between bodies: the all-pairs Newtonian force (refsim/models/
nbody_gravity.py `pair_accelerations`, softening included) is computed in numpy from MuJoCo's
current positions and handed to MuJoCo, one Python round trip per step (or per stage). Each
particle is a free body (`<freejoint>`, qpos = (centre, quaternion): the position is stored as
such, not as an offset), an explicit `<inertial>` with the scene's mass and diaginertia 1e-12
(docs/engine_notes.md#mujoco-point-mass-inertia), no geoms, contacts off, gravity the scene's,
every damping/armature 0 (MJCF defaults, nothing set), eulerdamp and autoreset off. Two
formulations:

- "" (xfrc_per_step): before every `mj_step`, `data.xfrc_applied` = m a(x_k) on each body (its
  centre of mass). MuJoCo holds xfrc_applied constant over the step, so RK4's four stages all
  see the force of the step's start: v_{k+1} = v_k + h a(x_k), x_{k+1} = x_k + h v_k + h^2/2
  a(x_k), a FIRST-order, non-symplectic step (measured: Kepler e = 0.5 return error falls at
  order 1.0, 0.33 at h = T/1600 where the callback form gives 3.5e-9). Euler, implicit and
  implicitfast evaluate the force once per step anyway: for them this is the kick-drift step.
- "passive_callback": `mujoco.set_mjcb_passive` installs a Python function that MuJoCo calls
  inside `mj_passive`, i.e. in every `mj_forward` / RK4 stage evaluation (mj_RungeKutta calls
  mj_forwardSkip per stage): it adds m a(x_stage) to `qfrc_passive` (a free joint's
  translational dofs are world-frame forces). RK4 keeps its fourth order (measured 4.07-4.13).
  MuJoCo's callbacks are process-global (mjcb_* are C globals, not per model): the Sim
  installs its callback around each step(n) call and restores the previous one in `finally`,
  so no other model ever runs with it; `mj_step(nstep=n)` then runs the n steps in C with one
  Python callback per force evaluation.

Facts measured here (mujoco 4.0.0, Kepler orbit): Euler is refsim's symplectic_euler (kick then
drift) to round-off; implicit and implicitfast take the same step (their implicit parts act on
damping and gyroscopic derivatives, both zero here), equal to Euler to round-off.
"""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from refsim.engine import ModelGroup
from refsim.models.nbody_gravity import pair_accelerations
from refsim.scene import Particles
from refsim.scene.gravity_pairs import GravityPairs

from ..methods import METHODS
from ..mjcf import xml_floats
from ..point_masses import POINT_INERTIA
from ..sim import BAD_WARNINGS, MujocoSim
from .rigid_sim import arena_bytes

INTEGRATORS = ("symplectic_euler", "rk4", "implicit", "implicitfast")
FORMULATIONS = {
    "": "xfrc_per_step: data.xfrc_applied = m a(x) set from Python before every mj_step; "
        "held constant over the step (RK4's 4 stages see the step-start force)",
    "passive_callback": "mujoco.set_mjcb_passive: m a(x) added to qfrc_passive at every "
                        "force evaluation (each RK4 stage), installed around each step(n)",
}
COST_NOTE = ("pair force computed in numpy and applied through {api} with one Python call per "
             "{unit}: that is this engine's real cost in this use")


def claims(scene) -> bool:
    return scene.part_kinds() == {"particles", "gravity_pairs"}


def build(engine, scene, dt, integrator, formulation):
    if integrator not in INTEGRATORS:
        raise ValueError(f"mujoco gravity_pairs integrator must be one of {list(INTEGRATORS)}, "
                         f"got {integrator!r}")
    return MujocoGravitySim(scene, dt, integrator, formulation)


MODEL_GROUP = ModelGroup(
    name="gravity_pairs", build=build, claims=claims,
    parts=frozenset({"particles", "gravity_pairs"}),
    features=frozenset({"gravity_pairs", "gravity"}),
    formulations=lambda engine, scene: tuple(FORMULATIONS), integrators=INTEGRATORS)


def effective_method(integrator: str, formulation: str):
    """The Method as refsim declares it for this formulation: RK4 with the force frozen over the
    step is first order and not symplectic (see the module docstring)."""
    method = METHODS[integrator]
    if integrator == "rk4" and formulation == "":
        return replace(method, order=1, note=(
            "RK4's 4 stages with xfrc_applied held at the step-start force: v += h a(x_k), "
            "x += h v_k + h^2/2 a(x_k): first order (measured 1.0), not symplectic"))
    if integrator in ("implicit", "implicitfast"):
        return replace(method, symplectic=True, note=(
            f"{method.note}. Here no force depends on velocity (no damping, no Coriolis term "
            "on free point masses): D = 0, and the step IS the symplectic (semi-implicit) "
            "Euler step, equal to MuJoCo's Euler to round-off (tested): declared symplectic"))
    return method


def gravity_scene_xml(scene, dt, method) -> str:
    """Free bodies at the particles' positions: explicit inertial, no geoms; explicit timestep,
    gravity and integrator; contacts, eulerdamp and autoreset off; arena sized for n bodies."""
    p = scene.part(Particles)
    inertia = xml_floats([POINT_INERTIA] * 3)
    bodies = "".join(f'<body name="b{i}" pos="{xml_floats(x)}"><freejoint name="b{i}_free"/>'
                     f'<inertial pos="0 0 0" mass="{xml_floats(m)}" diaginertia="{inertia}"/>'
                     f'</body>' for i, (m, x) in enumerate(zip(p.mass, p.position)))
    return (f'<mujoco model="refsim_gravity_pairs"><compiler inertiafromgeom="false"/>'
            f'<size memory="{arena_bytes(len(p))}"/>'
            f'<option timestep="{xml_floats(dt)}" gravity="{xml_floats(scene.gravity)}" '
            f'integrator="{method.xml}" density="0" viscosity="0" wind="0 0 0">'
            f'<flag contact="disable" eulerdamp="disable" autoreset="disable"/></option>'
            f'<worldbody>{bodies}</worldbody></mujoco>')


class MujocoGravitySim(MujocoSim):
    """Free bodies driven by the all-pairs force; stepping per formulation (module docstring)."""

    def __init__(self, scene, dt, integrator, formulation):
        import mujoco
        self.mj, self.scene, self.dt = mujoco, scene, dt
        self.integrator, self.formulation = integrator, formulation
        self.method = effective_method(integrator, formulation)
        self.plans, self.spheres, self.contact = [], False, None
        self.steps, self.failure, self._messages = 0, None, []
        part, particles = scene.part(GravityPairs), scene.part(Particles)
        self.G, self.softening = part.G, part.softening
        self.masses = np.array(particles.mass)
        self.n = n = len(self.masses)
        t0 = time.perf_counter()
        self.model = mujoco.MjModel.from_xml_string(gravity_scene_xml(scene, dt, self.method))
        self.compile_s = time.perf_counter() - t0
        self._check_model()
        self._check_masses()
        self.data = d = mujoco.MjData(self.model)
        self._x = d.qpos.reshape(n, 7)[:, :3]  # live views into mjData
        self._v = d.qvel.reshape(n, 6)[:, :3]
        self._v[:] = particles.velocity
        self._xfrc = d.xfrc_applied[1:n + 1, :3]
        self._qfrc = d.qfrc_passive.reshape(n, 6)[:, :3]
        self._bad = np.array([int(getattr(mujoco.mjtWarning, w)) for w in BAD_WARNINGS])
        self._counts = d.warning.number

    def _check_masses(self):
        m = self.model
        if not np.array_equal(m.body_mass[1:self.n + 1], self.masses) or \
                not np.array_equal(m.body_pos[1:self.n + 1],
                                   self.scene.part(Particles).position):
            raise RuntimeError("mujoco compiled other masses/positions than the scene's")

    def _forces(self):
        """m a(x) on every body at MuJoCo's current positions, (n, 3)."""
        return self.masses[:, None] * pair_accelerations(self._x, self.masses, self.G,
                                                         self.softening)

    # -- stepping -----------------------------------------------------------------------------
    def _step_impl(self, n):
        mj = self.mj
        previous = mj.get_mju_user_warning()
        mj.set_mju_user_warning(self._messages.append)  # no MUJOCO_LOG.TXT, no console
        try:
            if self.formulation == "passive_callback":
                self._step_with_callback(n)
            else:
                self._step_with_xfrc(n)
        finally:
            mj.set_mju_user_warning(previous)
        self._check_warnings()

    def _step_with_xfrc(self, n):
        step, model, data, xfrc, forces = self.mj.mj_step, self.model, self.data, self._xfrc, \
            self._forces
        for _ in range(n):  # one Python round trip per step: the force needs this step's x
            xfrc[:] = forces()
            step(model, data)

    def _step_with_callback(self, n):
        mj, qfrc, forces = self.mj, self._qfrc, self._forces

        def add_pair_forces(model, data):  # called by mj_passive at every force evaluation
            qfrc[:] += forces()

        previous = mj.get_mjcb_passive()
        mj.set_mjcb_passive(add_pair_forces)  # process-global: restored below
        try:
            mj.mj_step(self.model, self.data, nstep=int(n))
        finally:
            mj.set_mjcb_passive(previous)

    # -- observation --------------------------------------------------------------------------
    def _observe(self):
        """x = the free joints' positions (qpos), v = their world-frame linear velocities."""
        return {"x": self._x.copy(), "v": self._v.copy()}

    # -- settings -----------------------------------------------------------------------------
    def settings(self):
        out = self._base_settings()
        for key in ("bodies", "drag", "inertia", "step_call"):
            out.pop(key, None)
        callback = self.formulation == "passive_callback"
        out["integrator"].update(self._integrator_notes())
        out.update({
            "formulation": FORMULATIONS[self.formulation],
            "formulation_name": "passive_callback" if callback else "xfrc_per_step",
            "python_per_step": COST_NOTE.format(
                api="mujoco.set_mjcb_passive (qfrc_passive)" if callback else
                "data.xfrc_applied + mj_step",
                unit="force evaluation (1 per step, 4 per RK4 step; mj_step(nstep=n) runs the "
                     "loop in C)" if callback else "step (mj_step(model, data) per step)"),
            "pair_force": {"G": self.G, "softening": self.softening, "pairs": "all",
                           "kernel": "refsim.models.nbody_gravity.pair_accelerations (numpy)",
                           "applied_at": "each body's centre of mass (world frame)"},
            "bodies": {"count": self.n, "joint": "freejoint (qpos = centre, quaternion)",
                       "inertial": f"scene mass, diaginertia {POINT_INERTIA:g} (point mass)",
                       "geoms": "none (nothing collides)"},
            "callback_scope": ("mjcb_passive is process-global: installed around each step(n) "
                               "call, the previous one restored after" if callback else
                               "no callback installed"),
            "damping": "none: joint damping 0, armature 0, frictionloss 0 (MJCF defaults)",
        })
        return out

    def _integrator_notes(self) -> dict:
        staged = self.integrator == "rk4" and self.formulation == "passive_callback"
        return {"nominal_order": METHODS[self.integrator].order,
                "force_evaluations_per_step": 4 if staged else 1,
                "force_frozen_over_step": not staged}
