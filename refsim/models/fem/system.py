"""A P1 finite-element mesh (TriangleMesh or TetMesh part) as a system for the steppers of
refsim.integrators: accel, dense `jacobians` (small meshes) and `sparse_force_jacobians`
(Baraff-Witkin's sparse path), with lumped masses.

The state holds the FREE nodes' world positions and velocities, flat (3 n_free,); pinned nodes
stay at the mesh's `positions` (its rest vertices unless an imposed displacement moves them) with zero velocity (`full_positions` puts them back), as in
refsim.models.spring_network. Forces on the free nodes (N):
- elastic: f = -dU/dx of the ElasticBody (refsim.models.fem.model); a triangle mesh's forces
  lie in its plane (no stiffness normal to it: gravity and loads must lie in the plane);
- the mesh's constant nodal loads, and gravity m g with the lumped masses m = rho V / (d + 1)
  per element node (refsim.models.fem.assembly);
- optional Rayleigh damping f = -(alpha M + beta K(x)) v, alpha in 1/s, beta in s, with the
  lumped M and the tangent stiffness at the current positions (its x-derivative is left out
  of the Jacobians, as Baraff & Witkin leave out the damping direction's).
Plasticity (refsim.models.fem.plasticity): the stress is the return from the committed plastic
strain, stored per element in the system (`plastic_strain`) and updated by `commit(x)` after
an accepted step (`advance` steps and commits; the steppers themselves have no post-step hook).
Jacobians: df/dx = -K (the tangent, in world dofs: T^T K T with T the plane basis per node for
triangles), df/dv = -(alpha M + beta K). One flat state at a time (no batch axes).

`accel` (without beta damping, on the correct nodal force) composes the elements' two sparse
maps (refsim.models.fem.elements) with the world map T, the pinned nodes and the masses once:
Ds = E @ (x_free, x_pinned) and a = M^-1 T^T G @ P + M^-1 f_ext - alpha v, so a step is those
two products and the law's stress. It equals (f(x, v) / m) to round-off (the products sum
the same terms in another order: tests/models/test_fem_fast.py states the bound).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .tensors import components
from .model import ElasticBody
from .printed import body_and_assembler


def _world_map(body, n):
    """(n d, 3 n) sparse T with local = T world (per node the plane basis, or I for 3D)."""
    if body.basis is None:
        return sp.identity(3 * n, format="csr")
    return sp.kron(sp.identity(n), sp.csr_matrix(body.basis), format="csr")


class FemSystem:
    """One FEM mesh under gravity, its nodal loads and optional Rayleigh damping; `formulation`
    "as_printed" takes slide 001's printed nodal force (refsim.models.fem.printed)."""

    def __init__(self, mesh, gravity=(0.0, 0.0, 0.0), rayleigh=(0.0, 0.0), formulation=""):
        self.mesh = mesh
        self.body, self.assembler = body_and_assembler(mesh, formulation)
        self.n_nodes = len(mesh)
        self.free = np.ones(self.n_nodes, bool)
        self.free[mesh.pinned] = False
        self.nbody = int(self.free.sum())
        if self.nbody == 0:
            raise ValueError("mesh.pinned must leave at least one free node")
        self.gravity = np.asarray(gravity, float)
        self.alpha, self.beta = (float(r) for r in rayleigh)
        if self.alpha < 0 or self.beta < 0:
            raise ValueError(f"rayleigh damping (alpha, beta) must be >= 0, got {rayleigh}")
        if self.body.basis is not None:
            normal = np.cross(*self.body.basis)
            if abs(self.gravity @ normal) > 1e-12 * max(1.0, np.abs(self.gravity).max()):
                raise ValueError("gravity must lie in the triangle mesh's plane (no stiffness "
                                 "normal to it)")
        self.node_masses = self.assembler.lumped_mass(mesh.material.density)
        self.masses = self.node_masses[self.free]
        self.inv_m = (1.0 / self.masses)[:, None]
        self.external = (mesh.loads + self.node_masses[:, None] * self.gravity)[self.free]
        self.free_dofs = np.flatnonzero(np.repeat(self.free, 3))
        self.to_local = _world_map(self.body, self.n_nodes)[:, self.free_dofs].tocsr()
        self.linear = self.body.linear
        self.velocity_dependent = bool(self.alpha > 0 or self.beta > 0)
        self._rest = np.array(mesh.positions, float)  # initial; pinned nodes held here
        self._maps = None  # accel's composed maps, built on its first call

    def _composed_maps(self):
        """(E, G, a_ext, aug) of `accel` (module docstring): E (d d m, 3 n) on the state
        augmented by the pinned nodes' positions (aug, its free part refilled per call),
        G (3 n_free, d d m), a_ext = f_ext / m flat."""
        elements, n = self.body.elements, self.n_nodes
        order = np.r_[np.flatnonzero(self.free), np.flatnonzero(~self.free)]
        dofs = (3 * order[:, None] + np.arange(3)).reshape(-1)
        augment = sp.csr_matrix((np.ones(3 * n), (dofs, np.arange(3 * n))), shape=(3 * n, 3 * n))
        edges = (elements.edge_map @ (_world_map(self.body, n) @ augment)).tocsr()
        edges.eliminate_zeros()
        inv_m = np.repeat(self.inv_m[:, 0], 3)
        forces = (sp.diags(inv_m) @ (self.to_local.T @ elements.force_map)).tocsr()
        forces.eliminate_zeros()
        aug = np.empty(3 * n)
        aug[3 * self.nbody:] = self._rest[~self.free].reshape(-1)
        return edges, forces, self.external.reshape(-1) * inv_m, aug

    def describe(self) -> dict:
        return {**self.body.describe(), "free_nodes": self.nbody,
                "pinned": int(len(self.mesh.pinned)), "mass": "lumped (rho V / (d + 1))",
                "rayleigh_alpha_per_s": self.alpha, "rayleigh_beta_s": self.beta}

    def full_positions(self, x_free) -> np.ndarray:
        """(n_nodes, 3): the free nodes from the state, the pinned ones where the mesh holds
        them (its `positions`)."""
        out = self._rest.copy()
        out[self.free] = np.reshape(x_free, (self.nbody, 3))
        return out

    def full_velocities(self, v_free) -> np.ndarray:
        out = np.zeros((self.n_nodes, 3))
        out[self.free] = np.reshape(v_free, (self.nbody, 3))
        return out

    def _one(self, x):
        if np.ndim(x) != 1:
            raise ValueError("FemSystem takes one flat state (no batch axes)")

    def _stiffness(self, x) -> sp.csr_matrix:
        """K = -df/dx on the free world dofs, (3 n_free)^2."""
        local = self.body.to_local(self.full_positions(x))
        k = self.assembler.stiffness(local)
        return (self.to_local.T @ k @ self.to_local).tocsr()

    def elastic_forces(self, x) -> np.ndarray:
        """(n_free, 3) world elastic forces."""
        local = self.body.to_local(self.full_positions(x))
        return self.body.to_world(self.body.forces(local), vectors=True)[self.free]

    def forces(self, x, v) -> np.ndarray:
        self._one(x)
        f = self.elastic_forces(x) + self.external
        if self.alpha > 0:
            f = f - self.alpha * self.masses[:, None] * np.reshape(v, (-1, 3))
        if self.beta > 0:
            f = f - self.beta * (self._stiffness(x) @ v).reshape(-1, 3)
        return f

    def accel(self, t, x, v):
        if self.beta > 0 or type(self.body) is not ElasticBody:
            return (self.forces(x, v) * self.inv_m).reshape(-1)
        self._one(x)
        if self._maps is None:
            self._maps = self._composed_maps()
        edges, forces, a_ext, aug = self._maps
        aug[:3 * self.nbody] = x
        p = self.body.law.stress(self.body.elements.gradient_of_edges(edges @ aug))
        a = forces @ np.ascontiguousarray(components(p)).reshape(-1)
        a += a_ext
        if self.alpha > 0:
            a -= self.alpha * np.asarray(v, float)
        return a

    def sparse_force_jacobians(self, t, x, v):
        """(df/dx, df/dv) as CSR (3 n_free)^2 force Jacobians for one flat state."""
        if np.ndim(x) != 1:
            return None
        k = self._stiffness(x)
        kv = sp.csr_matrix(k.shape)
        if self.alpha > 0:
            kv = kv - sp.diags(self.alpha * np.repeat(self.masses, 3))
        if self.beta > 0:
            kv = kv - self.beta * k
        return -k, kv.tocsr()

    def jacobians(self, t, x, v):
        """Dense acceleration Jacobians (da/dx, da/dv) of one state (small meshes only)."""
        self._one(x)
        kx, kv = self.sparse_force_jacobians(t, x, v)
        inv_m = np.repeat(1.0 / self.masses, 3)[:, None]
        return inv_m * kx.toarray(), inv_m * kv.toarray()

    def potential_energy(self, x) -> float:
        """Elastic energy minus the work potential of loads and gravity (J; 0 at rest with
        positions measured from the origin)."""
        self._one(x)
        local = self.body.to_local(self.full_positions(x))
        return self.body.energy(local) - float(np.sum(self.external * np.reshape(x, (-1, 3))))

    def kinetic_energy(self, v) -> float:
        return float(0.5 * np.sum(self.masses[:, None] * np.reshape(v, (-1, 3)) ** 2))

    def commit(self, x) -> None:
        """After an accepted step: store each element's plastic strain at x (a plastic
        material; the steppers never call it, `advance` does)."""
        self.body.commit(self.body.to_local(self.full_positions(x)))

    def advance(self, stepper, t, state, h, n):
        """n steps of `stepper` from time t, committing the plastic strain after each (as
        MuJoCo updates its flex plasticity after the step); (t, state) as Integrator.advance.
        """
        for _ in range(n):
            t, state = stepper.advance(self, t, state, h, 1)
            self.commit(stepper.output(self, t, state, h)[0])
        return t, state

    @property
    def plastic_strain(self):
        """(m, 3, 3) per-element permanent strain (None for an elastic material)."""
        return getattr(self.body.law, "plastic_strain", None)

    def state(self):
        """(x, v) flat: the mesh's initial positions and velocities of the free nodes."""
        return (self._rest[self.free].reshape(-1).copy(),
                np.array(self.mesh.velocities, float)[self.free].reshape(-1))
