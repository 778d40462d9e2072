"""A compiled MuJoCo model of one scene: stepping, failure detection, observation, settings.

`MujocoSim` takes what its model group decided: the body plans, the contact setup of a sphere
scene (None: contacts off, point masses) and the number of rods (hinges) among the plans."""
from __future__ import annotations

import time

import numpy as np

from refsim.engine import Sim

from .methods import METHODS
from .mjcf import scene_xml
from .point_masses import POINT_INERTIA
from .spheres import rotate

BAD_WARNINGS = ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC", "mjWARN_INERTIA",
                "mjWARN_CONTACTFULL", "mjWARN_CNSTRFULL")  # full buffers drop contacts


class MujocoSim(Sim):
    rods = 0  # hinges among the plans: observed as a zero "constraint" each

    def __init__(self, scene, plans, dt, integrator, contact=None, rods=0):
        """`contact`: a callable () -> ContactSetup for a sphere scene (its restitution
        calibration counts as compilation), None for point masses without contacts."""
        import mujoco
        self.mj, self.scene, self.plans, self.dt = mujoco, scene, plans, dt
        self.integrator, self.method = integrator, METHODS[integrator]
        self.steps, self.failure, self._messages = 0, None, []
        self.spheres, self.rods = contact is not None, rods
        t0 = time.perf_counter()  # the restitution calibration (cached) counts as compilation
        self.contact = contact() if self.spheres else None
        xml = scene_xml(scene, plans, dt, self.method, self.contact)
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.compile_s = time.perf_counter() - t0
        self._check_model()
        self.data = mujoco.MjData(self.model)
        self.data.qvel[:] = np.concatenate([p.qvel0 for p in plans])
        self._bad = np.array([int(getattr(mujoco.mjtWarning, w)) for w in BAD_WARNINGS])
        self._counts = self.data.warning.number  # a live view of mjData.warning[:].number
        self._vel = np.zeros(6)

    # -- compiled model checks ----------------------------------------------------------------
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

    # -- stepping -----------------------------------------------------------------------------
    def _step_impl(self, n):
        mj = self.mj
        previous = mj.get_mju_user_warning()
        mj.set_mju_user_warning(self._messages.append)  # no MUJOCO_LOG.TXT, no console
        try:
            mj.mj_step(self.model, self.data, nstep=int(n))
        finally:
            mj.set_mju_user_warning(previous)
        self._check_warnings()

    def _check_warnings(self):
        """MuJoCo's bad-state warning counters (auto-reset is off) become `failure`; the base
        still counts the n steps taken, as MuJoCo took them."""
        counts = self._counts[self._bad]
        if counts.any():
            names = [w for w, c in zip(BAD_WARNINGS, counts) if c]
            text = "; ".join(m.strip() for m in self._messages) or "no message"
            self.failure = f"mujoco reported {', '.join(names)} ({text})"

    # -- observation --------------------------------------------------------------------------
    def _observe(self):
        if self.spheres:
            return self._observe_spheres()
        return self._observe_point_masses()

    def _observe_point_masses(self):
        """Body centres (xipos) and their world-frame linear velocities; a rod is a generalized
        coordinate, so its constraint residual is exactly zero."""
        mj, m, d = self.mj, self.model, self.data
        mj.mj_kinematics(m, d)
        mj.mj_comPos(m, d)
        mj.mj_comVel(m, d)
        n = len(self.plans)
        x, v = d.xipos[1:n + 1].copy(), np.empty((n, 3))
        for i in range(n):  # one C call per body, outside the timed loop
            mj.mj_objectVelocity(m, d, mj.mjtObj.mjOBJ_BODY, i + 1, self._vel, 0)
            v[i] = self._vel[3:]
        out = {"x": x, "v": v}
        if self.rods:
            out["constraint"] = np.zeros(self.rods)  # generalized coordinates
        return out

    def _observe_spheres(self):
        """Free joints: qpos = (centre, quaternion), qvel = (v world, w body frame)."""
        n = len(self.plans)
        q, qd = self.data.qpos.reshape(n, 7), self.data.qvel.reshape(n, 6)
        return {"x": q[:, :3].copy(), "v": qd[:, :3].copy(), "w": rotate(q[:, 3:], qd[:, 3:])}

    # -- settings -----------------------------------------------------------------------------
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

    def _stability_equivalent(self) -> dict:
        """The refsim stepper this method equals on this scene, where it differs from the
        engine's scene-independent `equivalents` (refsim stress's theory): `discrete` solves
        joint stiffness and damping implicitly but leaves gravity explicit, so on a hinge,
        whose restoring force is gravity's torque, it is the symplectic Euler step."""
        if self.integrator == "discrete" and self.rods:
            return {"stability_equivalent": "symplectic_euler",
                    "stability_equivalent_reason": "discrete: gravity's torque on the hinge is "
                    "explicit (only joint stiffness and damping are implicit), nothing is "
                    "damped: the symplectic Euler step"}
        return {}

    def _base_settings(self):
        m = self.method
        return {
            "integrator": {"name": self.integrator, "order": m.order, "family": m.family,
                           "explicit": m.explicit, "symplectic": m.symplectic,
                           "native": m.native, "note": m.note,
                           **self._stability_equivalent()},
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
            # the number itself, so that a case's bound can count what it adds (the
            # pendulum: (m L^2 + I) theta'' slows w0 by I / (2 m L^2))
            **({"point_inertia": POINT_INERTIA}
               if any(p.kind != "sphere" for p in self.plans) else {}),
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
