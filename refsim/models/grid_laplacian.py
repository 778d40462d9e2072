"""The finite-difference Laplacian of a regular grid (slides 000/001: the 3-, 5- and 7-point
stencils), applied by array slices and assembled as a scipy.sparse matrix; both are the same
operator, row for row.

Points x_j = origin + j h along each axis, j = 0..N-1. Per axis side (the `Grid` part's
`boundary`):
- "dirichlet": the points on that side are fixed; their rows of L are zero (u' = 0 keeps
  the initial values), their values enter their neighbours' rows as data;
- "neumann": zero normal derivative by the mirrored ghost point u_{-1} = u_1 (second order at
  the boundary point: (2 u_1 - 2 u_0) / h^2);
- "periodic": x_N is x_0 (the period is N h); both sides of the axis.

Eigenvectors (used by the cases' exact discrete references): on each axis of N points,
sin(k pi x_j / ((N-1) h)) for Dirichlet (k = 1..N-2), cos(k pi x_j / ((N-1) h)) for
Neumann on both sides (k = 0..N-1), cos or sin(2 pi k x_j / (N h)) for periodic; the
eigenvalue of the 3-point second difference for a mode of phase theta per point (k pi/(N-1)
resp. 2 pi k / N) is -(4 / h^2) sin^2(theta / 2) (`mode_eigenvalue`); in 2D/3D the sum over
axes. No Python loop over points: every axis is a few whole-array operations.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def mode_eigenvalue(theta, h):
    """-(4 / h^2) sin^2(theta / 2): the 3-point second difference on a mode of phase theta."""
    return -4.0 / h ** 2 * np.sin(0.5 * np.asarray(theta, float)) ** 2


def _second_difference(n: int, h: float, low: str, high: str) -> sp.csr_matrix:
    """The 1D operator of one axis (n points), rows of Dirichlet sides zero."""
    main, off = np.full(n, -2.0), np.ones(n - 1)
    upper, lower = off.copy(), off.copy()
    if low == "neumann":
        upper[0] = 2.0  # row 0: (2 u_1 - 2 u_0) / h^2
    if high == "neumann":
        lower[-1] = 2.0
    mat = sp.diags([lower, main, upper], [-1, 0, 1], format="lil")
    if low == "periodic":
        mat[0, n - 1] = 1.0
        mat[n - 1, 0] = 1.0
    if low == "dirichlet":
        mat[0, :] = 0.0
    if high == "dirichlet":
        mat[n - 1, :] = 0.0
    return (mat.tocsr() / h ** 2).tocsr()


class GridLaplacian:
    """L of a `Grid` part (or of shape, spacing, boundary given directly).

    `free`: bool mask of the points not on a Dirichlet side (the points that evolve);
    `apply(u, out=None)` -> L u by slices (zero on fixed points); `matrix()` -> the same
    operator as scipy.sparse CSR of size prod(shape), C order (axis 0 slowest).
    """

    def __init__(self, shape, spacing, boundary):
        self.shape = tuple(int(n) for n in shape)
        self.ndim = len(self.shape)
        self.spacing = tuple(float(h) for h in spacing)
        self.boundary = tuple(tuple(b) for b in boundary)
        free = np.ones(self.shape, bool)
        for axis, (low, high) in enumerate(self.boundary):
            index = [slice(None)] * self.ndim
            if low == "dirichlet":
                index[axis] = 0
                free[tuple(index)] = False
            if high == "dirichlet":
                index[axis] = -1
                free[tuple(index)] = False
        self.free = free
        self.all_free = bool(free.all())
        self._matrix = None

    @classmethod
    def of(cls, grid) -> GridLaplacian:
        return cls(grid.shape, grid.spacing, grid.boundary)

    @property
    def size(self) -> int:
        return int(np.prod(self.shape))

    def _axis(self, axis: int, u, out):
        """out += (second difference of u along axis) / h^2 (out's Dirichlet rows not yet
        masked)."""
        h2 = 1.0 / self.spacing[axis] ** 2
        low, high = self.boundary[axis]

        def part(s):
            index = [slice(None)] * u.ndim
            index[u.ndim - self.ndim + axis] = s
            return tuple(index)
        mid, up, down = part(slice(1, -1)), part(slice(2, None)), part(slice(None, -2))
        out[mid] += (u[up] - 2.0 * u[mid] + u[down]) * h2
        first, second, last, before = part(0), part(1), part(-1), part(-2)
        if low == "periodic":
            out[first] += (u[second] - 2.0 * u[first] + u[last]) * h2
            out[last] += (u[first] - 2.0 * u[last] + u[before]) * h2
            return
        if low == "neumann":
            out[first] += (2.0 * u[second] - 2.0 * u[first]) * h2
        if high == "neumann":
            out[last] += (2.0 * u[before] - 2.0 * u[last]) * h2

    def apply(self, u, out=None):
        """L u for u of shape (..., *shape) (leading batch axes allowed); zero at fixed points."""
        u = np.asarray(u, float)
        out = np.zeros_like(u) if out is None else out
        if out is not u:
            out[...] = 0.0
        for axis in range(self.ndim):
            self._axis(axis, u, out)
        if not self.all_free:
            out *= self.free
        return out

    def matrix(self) -> sp.csr_matrix:
        """The same operator as a sparse matrix (built once, cached)."""
        if self._matrix is None:
            eyes = [sp.identity(n, format="csr") for n in self.shape]
            total = None
            for axis, (n, h, (low, high)) in enumerate(zip(self.shape, self.spacing,
                                                          self.boundary)):
                factors = eyes[:axis] + [_second_difference(n, h, low, high)] + eyes[axis + 1:]
                term = factors[0]
                for f in factors[1:]:
                    term = sp.kron(term, f, format="csr")
                total = term if total is None else total + term
            if not self.all_free:
                total = sp.diags(self.free.reshape(-1).astype(float)) @ total
            self._matrix = total.tocsr()
        return self._matrix

    def spectral_radius_bound(self) -> float:
        """sum_axis 4 / h^2: |eigenvalue| of L never exceeds it (Gershgorin on each axis), and
        reaches it for periodic axes of even N (the sawtooth (-1)^j)."""
        return float(sum(4.0 / h ** 2 for h in self.spacing))

    def describe(self) -> str:
        points = {1: "3-point", 2: "5-point", 3: "7-point"}[self.ndim]
        sides = ", ".join(f"axis {a}: {lo}/{hi}" for a, (lo, hi) in enumerate(self.boundary))
        return (f"{points} Laplacian, h = {', '.join(f'{h:.6g}' for h in self.spacing)} m; "
                f"{sides} (Neumann by mirrored ghost point)")

