"""A `SpringNetwork` part (cloth, rope, hair) as a system for the steppers (slides 000-002):
stretch springs with damping along the edge, bending terms (hinges, dihedrals:
refsim.models.bending), linear air drag on every node, gravity, pinned nodes.

The state holds the FREE nodes only, flat (3 n_free,); pinned nodes stay at their initial
positions with zero velocity (`full_positions` puts them back). Forces in SI units:
- stretch edge (i, j), d = x_i - x_j, u = d / |d|: f_i = -[k (|d| - L0) + c (v_i - v_j) . u] u,
  f_j = -f_i (k in N/m: the slides' 000 convention K; slide 001's k_s in N is k r);
- drag: -c_air v on every node (scene.linear_drag, N s/m);
- gravity: m g.
An edge to a pinned node is a spring to a fixed anchor; an edge between two pinned nodes exerts
nothing on the state and is dropped. Jacobians are scipy.sparse (JacobianAssembler: pattern
found once); the dense `jacobians` exist for the small-state steppers (implicit Euler's Newton,
Baraff-Witkin below its sparse threshold).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .forces import SpringSet
from .spring_jacobians import JacobianAssembler


def stretch_springs(net) -> tuple[SpringSet, np.ndarray]:
    """(the network's stretch edges as a SpringSet on free-node indices, the kept edge rows)."""
    n = len(net)
    free = np.ones(n, bool)
    free[net.pinned] = False
    index = np.full(n, -1)
    index[free] = np.arange(free.sum())
    i, j = net.edges[:, 0], net.edges[:, 1]
    keep = free[i] | free[j]
    i, j = i[keep], j[keep]
    body = np.where(free[i], i, j)  # a free end
    other_node = np.where(free[i], j, i)
    other = np.where(free[other_node], index[other_node], -1)
    anchor = np.where((other < 0)[:, None], net.positions[other_node], 0.0)
    springs = SpringSet(body=index[body], other=other, anchor=anchor,
                        stiffness=net.stiffness[keep], rest=net.rest_length[keep],
                        damping=net.damping[keep])
    return springs, np.flatnonzero(keep)


def _bending_terms(net) -> list:
    if not (len(net.hinges) or len(net.dihedrals)):
        return []
    from .bending import bending_terms
    return bending_terms(net)


class NetworkSystem:
    """One spring network under gravity and drag, on its free nodes (see module doc)."""

    def __init__(self, net, gravity, drag=0.0):
        self.net, self.n_nodes = net, len(net)
        self.free = np.ones(self.n_nodes, bool)
        self.free[net.pinned] = False
        self.free_dofs = np.flatnonzero(np.repeat(self.free, 3))
        self.masses = np.asarray(net.masses, float)[self.free]
        self.nbody = len(self.masses)
        if self.nbody == 0:
            raise ValueError("network.pinned must leave at least one free node")
        self.gravity, self.drag = np.asarray(gravity, float), float(drag)
        self.springs, _ = stretch_springs(net)
        self.bending = _bending_terms(net)
        self.inv_m = (1.0 / self.masses)[:, None]
        self.g_accel = np.broadcast_to(self.gravity, (self.nbody, 3))
        self.linear = bool(np.all(self.springs.rest == 0) and not self.bending)
        self.velocity_dependent = bool(self.drag > 0 or self.springs.damping.any())
        self._assembler = None
        self._fixed = np.array(net.positions, float)  # pinned rows stay as given

    def describe(self) -> dict:
        kinds = sorted(self.net.edge_kinds())
        return {"nodes": self.n_nodes, "free_nodes": self.nbody,
                "pinned": int(len(self.net.pinned)), "stretch_edges": int(len(self.springs.body)),
                "hinges": int(len(self.net.hinges)), "dihedrals": int(len(self.net.dihedrals)),
                "terms": kinds, "air_drag_Ns_per_m": self.drag,
                "stretch_units": "k in N/m (slide 000's K; slide 001's k_s = K L0 in N)"}

    def full_positions(self, x_free) -> np.ndarray:
        """(..., n_nodes, 3): the free nodes from the state, the pinned ones fixed."""
        xb = np.asarray(x_free, float).reshape(np.shape(x_free)[:-1] + (self.nbody, 3))
        out = np.broadcast_to(self._fixed, xb.shape[:-2] + self._fixed.shape).copy()
        out[..., self.free, :] = xb
        return out

    def full_velocities(self, v_free) -> np.ndarray:
        vb = np.asarray(v_free, float).reshape(np.shape(v_free)[:-1] + (self.nbody, 3))
        out = np.zeros(vb.shape[:-2] + (self.n_nodes, 3))
        out[..., self.free, :] = vb
        return out

    def forces(self, x, v) -> np.ndarray:
        """Forces other than gravity on the free nodes, (..., nbody, 3)."""
        shape = np.shape(x)[:-1] + (self.nbody, 3)
        xb, vb = np.reshape(x, shape), np.reshape(v, shape)
        f = self.springs.forces(xb, vb)
        if self.drag > 0:
            f = f - self.drag * vb
        if self.bending:
            full = self.full_positions(x)
            for term in self.bending:
                f = f + term.forces(full)[..., self.free, :]
        return f

    def accel(self, t, x, v):
        a = self.forces(x, v) * self.inv_m + self.g_accel
        return a.reshape(np.shape(x))

    def sparse_force_jacobians(self, t, x, v):
        """(df/dx, df/dv) as CSR (3 n_free)^2 force Jacobians for one flat state."""
        if np.ndim(x) != 1:
            return None
        if self._assembler is None:
            self._assembler = JacobianAssembler(self.springs, self.nbody)
        kx, kv = self._assembler(np.reshape(x, (-1, 3)), np.reshape(v, (-1, 3)))
        if self.drag > 0:
            kv = kv - self.drag * sp.identity(3 * self.nbody, format="csr")
        if self.bending:
            full = self.full_positions(x)
            for term in self.bending:
                kx = kx + term.jacobian(full, self.free)
        return kx.tocsr(), kv

    def jacobians(self, t, x, v):
        """Dense acceleration Jacobians (da/dx, da/dv) of one state (small networks only)."""
        if np.ndim(x) != 1:
            raise ValueError("NetworkSystem.jacobians takes one flat state (no batch axes)")
        kx, kv = self.sparse_force_jacobians(t, x, v)
        inv_m = np.repeat(1.0 / self.masses, 3)[:, None]
        return inv_m * kx.toarray(), inv_m * kv.toarray()

    def potential_energy(self, x) -> float:
        """Stretch + bending + gravity potential energy of one state (J)."""
        return network_potential(self.net, self.full_positions(x), self.gravity,
                                 self.bending)


def network_potential(net, positions, gravity, bending=None) -> float:
    """Potential energy (J) of a network at node positions (n, 3): springs 1/2 k (|d| - L0)^2,
    bending terms, and -m g . x (zero at the origin)."""
    x = np.asarray(positions, float)
    d = x[net.edges[:, 0]] - x[net.edges[:, 1]]
    stretch = 0.5 * np.sum(net.stiffness * (np.linalg.norm(d, axis=1) - net.rest_length) ** 2)
    terms = _bending_terms(net) if bending is None else bending
    bend = sum(term.energy(x) for term in terms)
    return float(stretch + bend - np.sum(net.masses[:, None] * np.asarray(gravity) * x))


def kinetic_energy(net, velocities) -> float:
    v = np.asarray(velocities, float)
    return float(0.5 * np.sum(net.masses * np.einsum("ij,ij->i", v, v)))
