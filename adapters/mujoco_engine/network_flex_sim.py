"""A compiled MuJoCo model of a hair, formulation "flex" (adapters/mujoco_engine/network_flex):
a 1-D flexcomp rod for bending, spatial tendons for stretching.

The vertex bodies sit at the STRAIGHT reference chain in qpos0; the initial positions are set
as qpos displacements from it, and observed back as reference + qpos (vectorised reads of the
precomputed slide addresses). The per-edge twist joints flexcomp adds are not observed (refsim's
hinge has no torsion); their angles are reported by `twist_angles`."""
from __future__ import annotations

import numpy as np

from refsim_adapters.common.spring_network import observation

from .network_flex import (
    FLEX_NAME,
    SHEAR_RATIO,
    flex_model,
    rest_layout,
    rest_lengths,
    vertex_indices,
)
from .network_sim import MujocoNetworkSim
from .point_masses import POINT_INERTIA


class MujocoFlexSim(MujocoNetworkSim):
    """Free nodes: flexcomp vertex bodies (3 world-axis slides); pinned nodes: flex pins."""

    def _compile(self):
        model, self.rod = flex_model(self.scene, self.dt, self.method.xml, self.free)
        self._qpos_at, self._dof_at = vertex_indices(model, self.free)
        self._twist_qpos = np.setdiff1d(np.arange(model.nq), self._qpos_at.ravel())
        return model

    def _set_initial_state(self):
        self._x0 = rest_layout(self.net)
        start = np.asarray(self.net.positions, float) - self._x0
        self.data.qpos[self._qpos_at] = start[self.free]
        self.data.qvel[self._dof_at] = self.net.velocities[self.free]

    def _check_network(self):
        """Masses, slide axes, drag, tendons and the flex's rod parameters are the ones asked."""
        m, net = self.model, self.net
        bodies = m.jnt_bodyid[m.dof_jntid[self._dof_at[:, 0]]]
        axes = m.jnt_axis[m.dof_jntid[self._dof_at]]
        rec = m.flex_bending[m.flex_bendingadr[0] + 1:].reshape(-1, 10)
        ei_per_length = self.rod["young"] * self.rod["second_moment"]
        n_edges = len(self.edges)
        n_drag = 3 * int(self.free.sum()) if self.scene.linear_drag else 0
        same = (m.nflex == 1 and m.flex_dim[0] == 1 and
                np.array_equal(m.body_mass[bodies], net.masses[self.free]) and
                np.all(m.body_inertia[bodies] == POINT_INERTIA) and
                np.array_equal(axes, np.broadcast_to(np.eye(3), axes.shape)) and
                not m.dof_damping.any() and m.ntendon == n_edges + n_drag and
                np.array_equal(m.tendon_stiffness[:n_edges], net.stiffness[self.edges]) and
                np.array_equal(m.tendon_damping[:n_edges], net.damping[self.edges]) and
                np.all(m.tendon_damping[n_edges:] == self.scene.linear_drag) and
                not m.tendon_stiffness[n_edges:].any() and
                m.flex_damping[0] == 0 and m.flex_edgestiffness[0] == 0 and
                m.flex_edgedamping[0] == 0 and not m.dof_armature[self._dof_at].any() and
                len(rec) == len(net) - 2 and np.all(rec[:, 3] == -1) and
                np.all(rec[:, 5:7] == 0))
        k_mujoco = self._expected_vertex_stiffness(ei_per_length)
        if not same or not np.allclose(rec[:, 4], k_mujoco, rtol=1e-14, atol=0):
            raise RuntimeError("mujoco compiled another rod/masses/tendons than the hair's")

    def _expected_vertex_stiffness(self, ei: float) -> np.ndarray:
        """k = E I / (l0 + l1) per interior vertex (MuJoCo's record, 5th value)."""
        lengths = rest_lengths(self.net)
        return ei / (lengths[:-1] + lengths[1:])

    def twist_angles(self) -> np.ndarray:
        """The per-edge twist joint angles (rad): 0 in planar motion."""
        return self.data.qpos[self._twist_qpos].copy()

    # -- observation --------------------------------------------------------------------------
    def _observe(self):
        x, v = self._x0.copy(), np.zeros_like(self._x0)
        x[self.free] += self.data.qpos[self._qpos_at]
        v[self.free] = self.data.qvel[self._dof_at]
        x[~self.free] = self.net.positions[~self.free]
        return observation(x, v)

    # -- settings -----------------------------------------------------------------------------
    def _network_settings(self) -> dict:
        out = super()._network_settings()
        rod, net = self.rod, self.net
        out.update({
            "formulation": "flex: one 1-D flexcomp (discrete elastic rod, circle section) for "
                           "the hinges, spatial tendons (k, L0, c per edge) for stretching; "
                           "pinned nodes flex pins, free nodes flexcomp vertex bodies with 3 "
                           "world-axis slides",
            "bending": "MuJoCo: U = k |kb|^2 per interior vertex, k = E I / (l0 + l1), "
                       "|kb| = 2 tan(phi/2); mapped by E I = k_b (l0 + l1) / 2, so U = "
                       "1/2 k_b (2 tan(phi/2))^2 against refsim's 1/2 k_b phi^2: moment "
                       "k_b phi (1 + phi^2/3 + ...), relative excess phi^2/3",
            "rod_radius": rod["radius"], "young": rod["young"], "poisson": 0.0,
            "second_moment_area": rod["second_moment"],
            "bending_rigidity_EI": rod["young"] * rod["second_moment"],
            "shear": rod["shear"],
            "torsion": f"shear G = {SHEAR_RATIO:g} x young (refsim's hinge has no torsion); "
                       "flexcomp's per-edge twist hinge joints (twist bodies of mass 1e-9) "
                       "stay at 0 in planar motion; not observed",
            "twist_joints": len(self._twist_qpos),
            "rayleigh_damping": 0.0, "flex_edge_stiffness": 0.0, "flex_edge_damping": 0.0,
            "reference_configuration": "qpos0 = the straight chain through node 0 along node "
                                       "1 - node 0 with the rest lengths (hinge rest angles 0); "
                                       "initial positions set as qpos displacements",
            "inertia": f"vertex bodies: node mass, diaginertia {POINT_INERTIA:g} (edited in the "
                       "MjSpec: flexcomp's own mass is spread uniformly)",
            "flex_name": FLEX_NAME, "hinges": len(net.hinges),
            "observation": "x = reference + qpos, v = qvel of the vertex slides (vectorised "
                           "reads); pinned nodes at their given positions with v = 0",
        })
        return out
