"""A compiled MuJoCo model of a rigid-body scene: one free-jointed body per scene body.

Stepping, the bad-state warning counters and `close` are MujocoSim's; this class builds the
MJCF, sets the initial state (world w rotated into the free joint's body-frame qvel), checks the
compiled model and observes x, v, q, w (world), orientation_defect and MuJoCo's own energy."""
from __future__ import annotations

import time

import numpy as np

from refsim.scene import RigidBodies

from ..mjcf import xml_floats
from ..sim import BAD_WARNINGS, MujocoSim
from ..spheres import rotate

INERTIA_RTOL = 1e-14  # the compiled R diag(moments) R^T vs the scene tensor, relative to its
# largest entry: R (from the normalised compiled quaternion) is exact to a few ulps and each
# entry is a 3-term sum of products, so ~10 eps = 2.2e-15 is expected; 1e-14 leaves margin
# while catching any reordering or transposition of the tensor (errors of order 1)
ARENA_PER_BODY = 4096  # bytes of mjData arena per free body: measured peak use (maxuse_arena,
# mujoco 4.0.0) is 96 B/body for Euler and implicitfast, 800 for RK4, 3600 for implicit (linear
# in n from 10^3 to 10^4 bodies); the default arena failed to allocate 10^4 bodies
ARENA_BASE = 1 << 20  # bytes: the fixed part (MuJoCo's own default arena is a few MiB)


TREATED_IMPLICITLY = {  # what each integrator solves implicitly on free bodies
    "symplectic_euler": "nothing (velocity first, then positions with the new velocity)",
    "rk4": "nothing (explicit)",
    "implicit": "the velocity derivative of the gyroscopic (Coriolis/centripetal) force",
    "implicitfast": "the velocity derivative of each free body's gyroscopic force (mujoco "
                    ">= 3.11; other Coriolis/centripetal derivatives are skipped)",
}

def principal_frame(inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(moments (3,), axes (3, 3)) with inertia = axes diag(moments) axes^T and det axes = +1
    (a rotation: the inertial frame). A diagonal tensor keeps its diagonal and the identity
    (exact: no decomposition round-off)."""
    if not np.any(inertia - np.diag(np.diag(inertia))):
        return np.diag(inertia).copy(), np.eye(3)
    moments, axes = np.linalg.eigh(inertia)
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    return moments, axes


def arena_bytes(nbody: int) -> int:
    """mjData arena (MJCF <size memory>) for nbody free bodies, every integrator."""
    return ARENA_BASE + ARENA_PER_BODY * nbody


def conjugate(quat: np.ndarray) -> np.ndarray:
    return quat * np.array([1.0, -1.0, -1.0, -1.0])


def _body_xml(index, mass, position, orientation, inertia, mj) -> str:
    """One free body at its COM: <inertial> with the principal moments and axes (as quat)."""
    moments, axes = principal_frame(inertia)
    iquat = np.zeros(4)
    mj.mju_mat2Quat(iquat, np.ascontiguousarray(axes).ravel())
    return (f'<body name="r{index}" pos="{xml_floats(position)}" '
            f'quat="{xml_floats(orientation)}"><inertial pos="0 0 0" '
            f'quat="{xml_floats(iquat)}" mass="{xml_floats(mass)}" '
            f'diaginertia="{xml_floats(moments)}"/><freejoint name="r{index}_free"/></body>')


def rigid_scene_xml(scene, dt, method, mj) -> str:
    """MJCF: explicit timestep and gravity, no fluid forces, contacts/eulerdamp/autoreset off."""
    r = scene.part(RigidBodies)
    bodies = "".join(_body_xml(i, r.mass[i], r.position[i], r.orientation[i], r.inertia[i], mj)
                     for i in range(len(r)))  # build time only, one string per body
    return (f'<mujoco model="refsim_rigid"><compiler inertiafromgeom="false"/>'
            f'<size memory="{arena_bytes(len(r))}"/>'
            f'<option timestep="{xml_floats(dt)}" gravity="{xml_floats(scene.gravity)}" '
            f'integrator="{method.xml}" density="0" viscosity="0" wind="0 0 0">'
            f'<flag contact="disable" eulerdamp="disable" autoreset="disable"/></option>'
            f'<worldbody>{bodies}</worldbody></mujoco>')


# base-settings keys that describe the particle scenes, not rigid bodies
PARTICLE_SETTINGS = ("contacts", "inertia", "drag", "bodies", "armature", "frictionloss",
                     "joint_limits", "energy_flag", "eulerdamp")


def engine_energy(mj, model, data) -> float:
    """MuJoCo's own kinetic + potential energy of the current state."""
    # docs/engine_notes.md#mujoco-energy-after-mj_forward: energy describes the state only
    # after mj_forward
    mj.mj_forward(model, data)
    mj.mj_energyPos(model, data)
    mj.mj_energyVel(model, data)
    return float(data.energy[0] + data.energy[1])


def check_compiled_bodies(model, mj, mass, inertia, com_offset) -> None:
    """The compiled bodies 1..k carry exactly `mass` (k,) and the COM offsets `com_offset`
    (k, 3) from their frames, and `inertia` (k, 3, 3) to INERTIA_RTOL (MuJoCo stores principal
    moments and axes: the tensor is rebuilt from them); RuntimeError otherwise."""
    k = len(mass)
    rot = np.zeros((k, 9))
    for i in range(k):  # build time only
        mj.mju_quat2Mat(rot[i], model.body_iquat[i + 1])
    rot = rot.reshape(k, 3, 3)
    tensor = np.einsum("nij,nj,nkj->nik", rot, model.body_inertia[1:k + 1], rot)
    scale = np.abs(inertia).max(axis=(1, 2))
    if not (np.array_equal(model.body_mass[1:k + 1], mass) and
            np.array_equal(model.body_ipos[1:k + 1], com_offset) and
            np.all(np.abs(tensor - inertia).max(axis=(1, 2)) <= INERTIA_RTOL * scale)):
        raise RuntimeError("mujoco compiled other masses/inertias than the scene's")


class MujocoRigidSim(MujocoSim):
    """Free bodies: qpos (n, 7) = (x, q), qvel (n, 6) = (v world, w body frame)."""

    def __init__(self, scene, dt, integrator, method):
        import mujoco
        self.mj, self.scene, self.dt = mujoco, scene, dt
        self.integrator, self.method = integrator, method
        self.plans, self.spheres, self.contact = [], False, None
        self.steps, self.failure, self._messages = 0, None, []
        self.n = len(scene.part(RigidBodies))
        t0 = time.perf_counter()
        self.model = mujoco.MjModel.from_xml_string(rigid_scene_xml(scene, dt, method,
                                                                    mujoco))
        self.compile_s = time.perf_counter() - t0
        self._check_model()
        self._check_inertia()
        self.data = mujoco.MjData(self.model)
        self._set_initial_state()
        self._bad = np.array([int(getattr(mujoco.mjtWarning, w)) for w in BAD_WARNINGS])
        self._counts = self.data.warning.number

    def _set_initial_state(self):
        """qpos = the scene's exact (x, q) (MJCF text would be re-normalised by the compiler);
        qvel angular = R^T w, the free joint's body frame."""
        r = self.scene.part(RigidBodies)
        self.data.qpos[:] = np.hstack([r.position, r.orientation]).ravel()
        w_body = rotate(conjugate(r.orientation), r.angular_velocity)
        self.data.qvel[:] = np.hstack([r.velocity, w_body]).ravel()

    def _check_inertia(self):
        r = self.scene.part(RigidBodies)
        check_compiled_bodies(self.model, self.mj, r.mass, r.inertia, np.zeros((self.n, 3)))

    # -- observation --------------------------------------------------------------------------
    def _observe(self):
        """x, v: qpos/qvel linear parts (world); q: the stored quaternion as it is (MuJoCo keeps
        it normalised); w = R w_body; orientation_defect = |q|^2 - 1; engine_energy: MuJoCo's
        kinetic + potential energy of the whole scene (mj_forward, then mj_energyPos/Vel)."""
        qpos, qvel = self.data.qpos.reshape(self.n, 7), self.data.qvel.reshape(self.n, 6)
        q = qpos[:, 3:].copy()
        return {"x": qpos[:, :3].copy(), "v": qvel[:, :3].copy(), "q": q,
                "w": rotate(q, qvel[:, 3:]),
                "orientation_defect": np.einsum("ni,ni->n", q, q) - 1.0,
                "engine_energy": self._engine_energy()}

    def _engine_energy(self) -> float:
        return engine_energy(self.mj, self.model, self.data)

    # -- settings -----------------------------------------------------------------------------
    def settings(self):
        out = self._base_settings()
        for key in PARTICLE_SETTINGS:
            out.pop(key, None)
        out.update(self._rigid_settings())
        out["integrator"]["implicit"] = not self.method.explicit
        out["integrator"]["treated_implicitly"] = TREATED_IMPLICITLY[self.integrator]
        return out

    def _rigid_settings(self) -> dict:
        return {
            "formulation": "one <freejoint/> per body: qpos (COM, unit quaternion w x y z), "
                           "qvel (world linear velocity, body-frame angular velocity)",
            "bodies": self.n,
            "inertia": "explicit <inertial> at the COM: scene mass, principal moments "
                       "(diaginertia) and axes (inertial quat) of the scene's body-frame "
                       f"tensor; compiled tensor checked to {INERTIA_RTOL:g} relative; "
                       "inertiafromgeom=false; inertias with A + B < C refused "
                       "(balanceinertia never used)",
            "angular_velocity_frame": "scene w (world) rotated into the free joint's body "
                                      "frame at build (R^T w) and back when observed (R w)",
            "quaternion": "MuJoCo integrates the orientation by the exponential map of the "
                          "body-frame angular velocity and normalises qpos's quaternion after "
                          "every position update (mju_normalize4, skipped while ||q| - 1| <= "
                          "mjMINVAL = 1e-15): orientation_defect (|q|^2 - 1 of the stored "
                          "quaternion) stays within 2e-15 + round-off; the renormalisation "
                          "hides any drift of the update itself",
            "gyroscopic": "the bias force c = w x I w is MuJoCo's RNE term: explicit in "
                          "symplectic_euler and rk4; its velocity derivative implicit in "
                          "implicit and (mujoco >= 3.11, free bodies) implicitfast, which "
                          "then take the same step",
            "contacts": "disabled (flag contact=disable, no geoms)",
            "eulerdamp": "disabled (nothing is damped: no joint damping on free joints)",
            "damping": "none: free joints without damping, armature 0, frictionloss 0",
            "velocity_limits": "none (MuJoCo clamps no velocities)",
            "arena_bytes": arena_bytes(self.n),
            "arena_note": f"<size memory>: {ARENA_BASE} + {ARENA_PER_BODY} per body (peak "
                          "use measured: 96 B/body Euler and implicitfast, 800 RK4, 3600 "
                          "implicit)",
            "energy_flag": "off while stepping; engine_energy is read at observe() by "
                           "mj_forward + mj_energyPos + mj_energyVel (potential -m g.x)",
        }
