"""A compiled MuJoCo model of one spring network, formulation "tendon" (network_mjcf).

Stepping (mj_step with nstep, the bad-state warning counters) and `close` are MujocoSim's; this
class builds the MJCF, checks the compiled model against the scene, sets the initial
velocities and observes x, v of every node (pinned ones included) by vectorised reads of
qpos/qvel: qpos (n_free, 3) is the displacement of each free node from its initial position."""
from __future__ import annotations

import time

import numpy as np

from refsim.scene import SpringNetwork
from refsim_adapters.common.spring_network import free_mask, observation

from .network_mjcf import SOLVER_ITERATIONS, SOLVER_TOLERANCE, kept_edges, network_xml
from .point_masses import POINT_INERTIA
from .sim import BAD_WARNINGS, MujocoSim

# base-settings keys that describe particle scenes, replaced here
_PARTICLE_KEYS = ("contacts", "inertia", "drag", "bodies", "eulerdamp")


class MujocoNetworkSim(MujocoSim):
    """Free nodes as 3-slide bodies, pinned nodes as world sites, stretch edges as tendons."""

    def __init__(self, scene, dt, integrator, method, treated_implicitly: str):
        import mujoco
        self.mj, self.scene, self.dt = mujoco, scene, dt
        self.integrator, self.method = integrator, method
        self.treated_implicitly = treated_implicitly
        self.plans, self.spheres, self.contact = [], False, None
        self.steps, self.failure, self._messages = 0, None, []
        self.net = scene.parts_of(SpringNetwork)[0]
        self.free = free_mask(self.net)
        self.edges = kept_edges(self.net, self.free)
        t0 = time.perf_counter()
        self.model = self._compile()
        self.compile_s = time.perf_counter() - t0
        self._check_model()
        self._check_network()
        self.data = mujoco.MjData(self.model)
        self._set_initial_state()
        self._bad = np.array([int(getattr(mujoco.mjtWarning, w)) for w in BAD_WARNINGS])
        self._counts = self.data.warning.number

    def _compile(self):
        xml = network_xml(self.scene, self.dt, self.method.xml, self.free)
        return self.mj.MjModel.from_xml_string(xml)

    def _set_initial_state(self):
        """qpos = 0 (the bodies sit at the initial positions), qvel = the free velocities."""
        self.data.qvel[:] = self.net.velocities[self.free].ravel()
        self._x0 = np.array(self.net.positions, float)

    def _check_network(self):
        """The compiled masses and tendon parameters are the scene's, exactly."""
        m, net = self.model, self.net
        n_free = int(self.free.sum())
        same = (m.nv == 3 * n_free and m.ntendon == len(self.edges) and
                np.array_equal(m.body_mass[1:n_free + 1], net.masses[self.free]) and
                np.array_equal(m.tendon_stiffness, net.stiffness[self.edges]) and
                np.array_equal(m.tendon_lengthspring, np.repeat(net.rest_length[self.edges, None], 2, 1)) and
                np.array_equal(m.tendon_damping, net.damping[self.edges]) and
                not m.tendon_stiffnesspoly.any() and not m.tendon_dampingpoly.any() and
                np.all(m.dof_damping == self.scene.linear_drag) and not m.dof_armature.any())
        if not same:
            raise RuntimeError("mujoco compiled other masses/tendons/damping than the network's")

    # -- observation --------------------------------------------------------------------------
    def _observe(self):
        """x = initial position + qpos displacement (free nodes), the pinned positions as
        given; v = qvel (free nodes), 0 for pinned ones."""
        x, v = self._x0.copy(), np.zeros_like(self._x0)
        x[self.free] += self.data.qpos.reshape(-1, 3)
        v[self.free] = self.data.qvel.reshape(-1, 3)
        return observation(x, v)

    # -- settings -----------------------------------------------------------------------------
    def settings(self):
        out = self._base_settings()
        for key in _PARTICLE_KEYS:
            out.pop(key, None)
        out["integrator"]["implicit"] = not self.method.explicit
        out["integrator"]["treated_implicitly"] = self.treated_implicitly
        out.update(self._network_settings())
        return out

    def _network_settings(self) -> dict:
        net = self.net
        return {
            "formulation": "tendon: every free node a body with 3 slide joints (x, y, z; no "
                           "rotation), every pinned node a site on the world body, every "
                           "stretch edge a spatial tendon between two sites with stiffness k, "
                           "springlength L0, damping c: exactly the in-house stretch model",
            "nodes": len(net), "free_nodes": int(self.free.sum()),
            "pinned": len(net.pinned), "tendons": len(self.edges),
            "edges_dropped": int(len(net.edges) - len(self.edges)),
            "edges_dropped_reason": "both ends pinned: exerts nothing on a free node",
            "tendon": "spatial, two sites: force -k (L - L0) - c dL/dt along it; "
                      "polynomial terms 0, armature 0, frictionloss 0, no limits, no "
                      "springyield (elastic)",
            "inertia": f"explicit <inertial>: node mass, diaginertia {POINT_INERTIA:g} "
                       "(no rotational dof: the inertia never enters)",
            "drag": "air drag -c_air v as joint damping c_air on each slide joint (exact: "
                    "the slide axes are the world axes)",
            "joint_damping": float(self.scene.linear_drag),
            "joint_stiffness": 0.0,
            "eulerdamp": "disabled (Euler would otherwise treat joint damping implicitly)",
            "contacts": "disabled (flag contact=disable, no geoms)",
            "solver": f"Newton, tolerance {SOLVER_TOLERANCE:g}, {SOLVER_ITERATIONS} "
                      "iterations (no constraints: only discrete's smooth step uses it)",
            "velocity_limits": "none (MuJoCo clamps no velocities)",
            "observation": "x = initial position + qpos, v = qvel per free node (vectorised "
                           "reads); pinned nodes at their given positions with v = 0",
        }
