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
"""
from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp


def edge_matrices(x, cells):
    """(m, d, d) matrices whose columns are x_a - x_0, a = 1..d (x: (n, d))."""
    x = np.asarray(x, float)
    return np.swapaxes(x[cells[:, 1:]] - x[cells[:, :1]], 1, 2)


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

    def deformation_gradient(self, x):
        """F = Ds Dm^-1, (m, d, d), for node positions x (n, d)."""
        return edge_matrices(x, self.cells) @ self.dm_inv

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
        """(n, d) internal forces of the element stresses P (m, d, d)."""
        return self.gather(self.element_forces(p))

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
