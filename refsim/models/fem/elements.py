"""P1 simplex elements (triangles in their plane, tetrahedra), vectorised over elements:
rest shape matrices, deformation gradients and nodal forces (Sifakis & Barbic, FEM Simulation
of 3D Deformable Solids, SIGGRAPH 2012 course notes, sec. 4; slide 001).

An element of d + 1 nodes x_0..x_d in d dimensions (rest positions X):
- Dm = [X_1 - X_0, ..., X_d - X_0] (columns), rest measure V = det(Dm) / d! (times the
  thickness for triangles); Dm must have det > 0 (positively oriented);
- deformation gradient F = Ds Dm^-1, Ds = [x_1 - x_0, ..., x_d - x_0] (slide 001's
  F = (x10 x20)(u10 u20)^-1): constant on the element;
- shape-function gradients grad phi_a = row a - 1 of Dm^-1 (a >= 1), grad phi_0 = -sum;
- nodal forces of a first Piola stress P: f_a = -V P grad phi_a, i.e. the columns of
  H = -V P Dm^-T on nodes 1..d and -sum on node 0 (= -dU/dx for U = V Psi(F)). In terms of
  the faces: f_a = (V |grad phi_a|) P n_a with n_a the unit outward normal of the face
  opposite node a, and V |grad phi_a| = t |e_a| / 2 (triangles, edge length |e_a|, thickness
  t) or A_a / 3 (tetrahedra, face area A_a): the closed integral of sigma n split per node.
Slide 001 prints the nodal force as f_i = Q sigma n_i: without the area weight (t |e|/2) and
with unit normals, so forces on one element no longer sum to zero (`slide_printed_forces`
runs it as printed, for comparison only; docs/models.md#fem-the-printed-nodal-force).

Element values are summed into nodes by one sparse product with the incidence matrix built
once (`scatter`), never a loop over elements or nodes.

The explicit force path (deformation_gradient, nodal_forces) is three sparse products built
once per mesh (on first use) around the law's stress, with F and P stored component by
component (memory (d, d, m), seen as (m, d, d): tensors.by_components), so each entry of a
law's closed form is one contiguous pass over the elements: `edge_map` (d d m, n d) gives the
edge vectors Ds = x_k - x_0 (entries +1 and -1: the same single rounding as the subtraction),
`gradient_map` F = Ds Dm^-1 (the matmul's sums in its order), and `force_map` (n d, d d m),
entries -V grad phi_a,j, sums f_a,i = -sum_e,j V_e P_ij grad phi_a,j: the element forces and
their scatter in one product. The maps drop exact zeros (a right triangle's zero gradient
components: 22-30 % fewer entries on the benchmark's square). The matrix route (element_forces,
gather) stays for the printed force and the tests. Timings: benchmarks/fem.py, item 3.
"""
from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from .tensors import components


def edge_matrices(x, cells):
    """(m, d, d) matrices whose columns are x_a - x_0, a = 1..d (x: (n, d))."""
    x = np.asarray(x, float)
    return np.swapaxes(x[cells[:, 1:]] - x[cells[:, :1]], 1, 2)


def edge_operator(cells, n):
    """(d d m, n d) CSR: row (i d + k) m + e gives component i of element e's edge k + 1,
    x_(k+1),i - x_0,i, of the flat node-major positions (n d,) (entries +1 and -1, so one
    rounding: the subtraction's)."""
    m, d = len(cells), cells.shape[1] - 1
    i = np.arange(d)[:, None, None]  # (i, k, e)
    tip = cells[:, 1:].T[None] * d + i
    base = np.broadcast_to(cells[:, 0] * d + i, tip.shape)
    rows = np.arange(d * d * m)
    return sp.csr_matrix((np.r_[np.ones(rows.size), -np.ones(rows.size)],
                          (np.r_[rows, rows], np.r_[tip.reshape(-1), base.reshape(-1)])),
                         shape=(d * d * m, n * d))


def gradient_operator(dm_inv):
    """(d d m, d d m) CSR: F = Ds Dm^-1 as one product on the edge vectors flat (i, k, e):
    row (i d + j) m + e holds (Dm^-1)_kj at column (i d + k) m + e, so F_ij = sum_k Ds_ik
    (Dm^-1)_kj in k order, as numpy's matmul sums it; exact zeros dropped (x 0 adds 0)."""
    m, d = dm_inv.shape[:2]
    i, j, k = np.meshgrid(np.arange(d), np.arange(d), np.arange(d), indexing="ij")
    e = np.arange(m)
    rows = np.broadcast_to((i * d + j)[..., None] * m + e, (d, d, d, m))
    cols = np.broadcast_to((i * d + k)[..., None] * m + e, (d, d, d, m))
    vals = np.broadcast_to(np.moveaxis(dm_inv, 0, -1)[None], (d, d, d, m))  # [k, j, e]
    vals = np.moveaxis(vals, 1, 2)  # (i, j, k, e): (Dm^-1)_kj
    g = sp.csr_matrix((vals.reshape(-1), (rows.reshape(-1), cols.reshape(-1))),
                      shape=(d * d * m, d * d * m))
    g.eliminate_zeros()
    return g


def force_operator(cells, n, grad, volume):
    """(n d, d d m) CSR: f = G @ P, P's components flat (i, j, e) (memory of `by_components`),
    f_a,i = -sum_e,j V_e grad phi_a,j(e) P_ij(e) node-major; exact zeros dropped."""
    m, d1 = cells.shape
    d = d1 - 1
    i, a, j = np.meshgrid(np.arange(d), np.arange(d1), np.arange(d), indexing="ij")
    rows = cells.T[None, :, None, :] * d + i[..., None]  # (i, a, j, e)
    cols = (i * d + j)[..., None] * m + np.arange(m)
    vals = np.broadcast_to(-volume * np.moveaxis(grad, 0, -1)[None], rows.shape)
    g = sp.csr_matrix((vals.reshape(-1), (rows.reshape(-1), cols.reshape(-1))),
                      shape=(n * d, d * d * m))
    g.eliminate_zeros()
    return g


def incidence(cells, n):
    """(n, m (d + 1)) CSR: node-by-(element, local node) ones; S @ values sums element values
    into their nodes."""
    m, k = cells.shape
    cols = np.arange(m * k)
    return sp.csr_matrix((np.ones(m * k), (cells.reshape(-1), cols)), shape=(n, m * k))


class Elements:
    """P1 simplices: rest positions (n, d), cells (m, d + 1) node indices, thickness (2D).

    Attributes: dm, dm_inv (m, d, d); volume (m,) (area x thickness for triangles); grad
    (m, d + 1, d) shape-function gradients; scatter (incidence)."""

    def __init__(self, rest, cells, thickness=1.0):
        self.rest = np.asarray(rest, float)
        self.cells = np.asarray(cells, np.int64)
        self.n, self.d = self.rest.shape
        self.m = len(self.cells)
        if self.cells.shape != (self.m, self.d + 1):
            raise ValueError(f"cells must have shape (m, {self.d + 1}), got {self.cells.shape}")
        self.dm = edge_matrices(self.rest, self.cells)
        det = np.linalg.det(self.dm)
        if np.any(det <= 0):
            bad = np.flatnonzero(det <= 0)
            raise ValueError(f"elements {bad[:8].tolist()} are inverted or degenerate "
                             f"(det Dm <= 0; {len(bad)} of {self.m}): orient every element "
                             "positively")
        self.dm_inv = np.linalg.inv(self.dm)
        self.thickness = float(thickness) if self.d == 2 else 1.0
        self.volume = det / math.factorial(self.d) * self.thickness
        self.grad = np.concatenate([-np.sum(self.dm_inv, 1, keepdims=True), self.dm_inv], 1)
        self.scatter = incidence(self.cells, self.n)
        self._edge_map = self._gradient_map = self._force_map = None

    @property
    def edge_map(self):
        """The edge operator (edge_operator), built on first use."""
        if self._edge_map is None:
            self._edge_map = edge_operator(self.cells, self.n)
        return self._edge_map

    @property
    def force_map(self):
        """The force operator (force_operator), built on first use."""
        if self._force_map is None:
            self._force_map = force_operator(self.cells, self.n, self.grad, self.volume)
        return self._force_map

    @property
    def gradient_map(self):
        """The gradient operator (gradient_operator), built on first use."""
        if self._gradient_map is None:
            self._gradient_map = gradient_operator(self.dm_inv)
        return self._gradient_map

    def gradient_of_edges(self, ds):
        """F = Ds Dm^-1 (m, d, d), component-wise memory, of the edge vectors ds (d d m,) flat
        (i, k, e) as `edge_map` gives them (`gradient_map`)."""
        f = self.gradient_map @ ds
        return np.moveaxis(f.reshape(self.d, self.d, self.m), (0, 1), (-2, -1))

    def deformation_gradient(self, x):
        """F = Ds Dm^-1, (m, d, d) (component-wise memory), for node positions x (n, d)."""
        flat = np.ascontiguousarray(x, dtype=float).reshape(-1)
        return self.gradient_of_edges(self.edge_map @ flat)

    def element_forces(self, p):
        """(m, d + 1, d): f_a = -V P grad phi_a per element node (H = -V P Dm^-T)."""
        h = -self.volume[:, None, None] * (p @ np.swapaxes(self.dm_inv, 1, 2))
        h = np.swapaxes(h, 1, 2)  # rows: nodes 1..d
        return np.concatenate([-np.sum(h, 1, keepdims=True), h], 1)

    def gather(self, values):
        """Sum per-element-node values (m, d + 1, ...) into nodes: (n, ...)."""
        flat = values.reshape(self.m * (self.d + 1), -1)
        return np.asarray(self.scatter @ flat).reshape((self.n,) + values.shape[2:])

    def nodal_forces(self, p):
        """(n, d) internal forces of the element stresses P (m, d, d): the force operator on
        P's components (no copy where P has component-wise memory)."""
        flat = np.ascontiguousarray(components(p), dtype=float).reshape(-1)
        return (self.force_map @ flat).reshape(self.n, self.d)

    def face_normals(self):
        """(m, d + 1, d) unit outward normals of the face opposite each node (rest shape):
        -grad phi_a / |grad phi_a|."""
        return -self.grad / np.linalg.norm(self.grad, axis=2, keepdims=True)

    def face_weights(self):
        """(m, d + 1): V |grad phi_a| = t |e_a| / 2 (triangles) or A_a / 3 (tetrahedra)."""
        return self.volume[:, None] * np.linalg.norm(self.grad, axis=2)


def slide_printed_forces(elements: Elements, p):
    """Slide 001's printed nodal force f_i = Q sigma n_i, per element node (m, d + 1, d): the
    stress (P = Q sigma) times the UNIT outward normal of the face opposite node i, without
    the face weight t |e_i| / 2 (A_i / 3 in 3D). The correct force is this times
    `face_weights()`; unweighted, the forces on an element sum to P sum_i n_i, which is zero
    only where all faces have equal size (an equilateral triangle): elsewhere the printed
    force pushes a uniformly stressed element along, and its units are N/m^2, not N."""
    return np.einsum("mij,maj->mai", p, elements.face_normals())
