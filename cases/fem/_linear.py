"""Linear elasticity on P1 triangles written out here from the textbook element (Zienkiewicz &
Taylor, The Finite Element Method, vol. 1, 6th ed. 2005, sec. 6.2: the constant-strain
triangle), independently of refsim.models, so that the FEM cases' exact discrete solutions
(the answer a correct P1 solver must give on the case's mesh) do not come from the code they
judge.

Element e with corners (x_a, y_a), a = 0, 1, 2, area A, thickness t: b_a = y_{a+1} - y_{a+2},
c_a = x_{a+2} - x_{a+1} (indices mod 3), strain (eps_xx, eps_yy, gamma_xy) = B u_e with
B = [[b_a, 0], [0, c_a], [c_a, b_a]]_a / (2 A), stiffness k_e = t A B^T D B with
    plane stress  D = E / (1 - nu^2) [[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]],
    plane strain  D = E / ((1 + nu)(1 - 2 nu)) [[1 - nu, nu, 0], [nu, 1 - nu, 0],
                                                 [0, 0, (1 - 2 nu) / 2]];
dofs interleaved (u_0, v_0, u_1, v_1, ...); lumped mass rho t A / 3 per corner. `solve`
holds prescribed dofs at their values and solves the rest with SuperLU (scipy).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve


def elasticity_matrix(youngs_modulus, poisson_ratio, plane="stress") -> np.ndarray:
    e, nu = float(youngs_modulus), float(poisson_ratio)
    if plane == "stress":
        return e / (1 - nu * nu) * np.array([[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]])
    return e / ((1 + nu) * (1 - 2 * nu)) * np.array(
        [[1 - nu, nu, 0], [nu, 1 - nu, 0], [0, 0, (1 - 2 * nu) / 2]])


def _b_matrices(nodes, triangles):
    """(B (m, 3, 6), areas (m,)) of the constant-strain triangles."""
    xy = np.asarray(nodes, float)[:, :2][triangles]  # (m, 3, 2)
    x, y = xy[..., 0], xy[..., 1]
    b = np.roll(y, -1, 1) - np.roll(y, -2, 1)
    c = np.roll(x, -2, 1) - np.roll(x, -1, 1)
    area = 0.5 * (x[:, 0] * b[:, 0] + x[:, 1] * b[:, 1] + x[:, 2] * b[:, 2])
    m = len(triangles)
    bm = np.zeros((m, 3, 6))
    bm[:, 0, 0::2], bm[:, 1, 1::2] = b, c
    bm[:, 2, 0::2], bm[:, 2, 1::2] = c, b
    return bm / (2 * area)[:, None, None], area


def stiffness(nodes, triangles, youngs_modulus, poisson_ratio, thickness=1.0,
              plane="stress") -> sp.csr_matrix:
    """(2 n, 2 n) CSR global stiffness of the P1 mesh (module docstring)."""
    bm, area = _b_matrices(nodes, triangles)
    d = elasticity_matrix(youngs_modulus, poisson_ratio, plane)
    ke = thickness * area[:, None, None] * np.einsum("mki,kl,mlj->mij", bm, d, bm)
    dofs = np.stack([2 * triangles, 2 * triangles + 1], -1).reshape(len(triangles), 6)
    rows = np.repeat(dofs, 6, 1).reshape(-1)
    cols = np.tile(dofs, (1, 6)).reshape(-1)
    n = 2 * len(nodes)
    return sp.csr_matrix((ke.reshape(-1), (rows, cols)), shape=(n, n))


def lumped_mass(nodes, triangles, density, thickness=1.0) -> np.ndarray:
    """(n,) node masses rho t A / 3 from each triangle."""
    _, area = _b_matrices(nodes, triangles)
    return np.bincount(triangles.reshape(-1), np.repeat(density * thickness * area / 3, 3),
                       minlength=len(nodes))


def solve(k, loads, fixed, values) -> np.ndarray:
    """(2 n,) displacements u with K u = f on the free dofs, u = values on the fixed ones
    (fixed: (2 n,) bool; loads, values: (2 n,))."""
    k = k.tocsr()
    free = ~np.asarray(fixed, bool)
    u = np.where(free, 0.0, np.asarray(values, float))
    rhs = np.asarray(loads, float)[free] - k[free][:, ~free] @ u[~free]
    u[free] = spsolve(k[free][:, free].tocsc(), rhs)
    return u
