"""Cell-centred geometric multigrid for the MAC pressure matrix A = G^T G (walls: homogeneous
Neumann; periodic axes), used as the preconditioner of CG (MGPCG, McAdams, Sifakis & Teran
2010): the projection's "multigrid" solver.

Why not refsim.models.multigrid: it coarsens vertex-centred grids of 2^k + 1 points with
Dirichlet sides; the MAC pressure lives at cell centres, Neumann or periodic, singular.
Levels: the fine grid's cells (nx, ny), then both halved (h doubled) while both are even and
above MIN_COARSE cells; every level rediscretises A (5-point, a missing wall neighbour
dropped from the row: Neumann).
- smoother: red-black Gauss-Seidel (colour = parity of i + j; both counts even, so the colours
  also alternate across a periodic seam), each colour one array update
  p = (sum of the real neighbours + h^2 b) / (their count);
- prolongation P: cell-centred bilinear (1D weights 3/4 and 1/4 from the nearest two coarse
  cells; a wall's ghost is the edge cell, periodic wraps), a scipy.sparse Kronecker product;
  restriction R = P^T / 4 (so that the V-cycle is symmetric);
- coarsest level: SuperLU of its matrix, the first cell pinned where singular;
- V(nu, nu) cycle from z = 0, post-sweeps black-then-red (the adjoint order): a symmetric
  preconditioner; where A is singular (no air: always here) its output's mean is removed, so
  that CG stays in A's range.
Only grids of FLUID cells (no marks) are taken: air and solid cells change the operator's
pattern level by level, which this hierarchy does not rediscretise (`multigrid_reason`).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

MIN_COARSE = 4  # cells per axis on the coarsest level (at most 8: then 64 unknowns, one LU)


def multigrid_reason(cells, marks=None) -> str | None:
    if marks is not None and np.any(np.asarray(marks) != 0):
        return "projection multigrid: grids of fluid cells only (no air or solid marks)"
    if any(n % 2 or n < 2 * MIN_COARSE for n in cells):
        return (f"projection multigrid: cells per axis even and at least {2 * MIN_COARSE} "
                f"(halved per level), got {tuple(cells)}")
    return None


def _prolong_1d(n: int, periodic: bool) -> sp.csr_matrix:
    """(2n x n): fine 2I from 3/4 e[I] + 1/4 e[I-1], fine 2I+1 from 3/4 e[I] + 1/4 e[I+1]."""
    coarse = np.arange(n)
    left = (coarse - 1) % n if periodic else np.maximum(coarse - 1, 0)
    right = (coarse + 1) % n if periodic else np.minimum(coarse + 1, n - 1)
    rows = np.concatenate([2 * coarse, 2 * coarse, 2 * coarse + 1, 2 * coarse + 1])
    cols = np.concatenate([coarse, left, coarse, right])
    vals = np.concatenate([np.full(n, 0.75), np.full(n, 0.25)] * 2)
    return sp.csr_matrix((vals, (rows, cols)), shape=(2 * n, n))  # duplicates sum (edges)


class Level:
    """One grid: its cells, h, neighbour counts and colour sub-lattices. Its fields are held
    padded by one ghost layer ((nx + 2, ny + 2), `inner` the cells): a wall's ghost is the edge
    cell itself (its term cancels: Neumann), a periodic axis' the opposite edge."""

    def __init__(self, cells, h, periodic):
        self.cells, self.h, self.periodic = tuple(cells), float(h), tuple(periodic)
        nx, ny = self.cells
        count = np.full(self.cells, 4.0)
        if not periodic[0]:
            count[[0, -1], :] -= 1
        if not periodic[1]:
            count[:, [0, -1]] -= 1
        self.count = count
        self.self_ghosts = 4.0 - count  # wall ghosts (equal to the cell) in a padded sum
        self.inner = (slice(1, nx + 1), slice(1, ny + 1))
        # colour 0 (red: i + j even) = sub-lattices (0, 0) and (1, 1); colour 1 the others
        self.lattices = tuple(tuple(self._lattice(a, b) for a, b in pairs)
                              for pairs in (((0, 0), (1, 1)), ((0, 1), (1, 0))))

    def _lattice(self, a, b):
        nx, ny = self.cells
        sub = (slice(a, nx, 2), slice(b, ny, 2))
        padded = (slice(1 + a, nx + 1, 2), slice(1 + b, ny + 1, 2))
        return padded, sub, self.count[sub], self.self_ghosts[sub]

    def padded(self, p=None) -> np.ndarray:
        q = np.zeros((self.cells[0] + 2, self.cells[1] + 2))
        if p is not None:
            q[self.inner] = p
        return q

    def fill_ghosts(self, q) -> None:
        if self.periodic[0]:
            q[0, 1:-1], q[-1, 1:-1] = q[-2, 1:-1], q[1, 1:-1]
        else:
            q[0, 1:-1], q[-1, 1:-1] = q[1, 1:-1], q[-2, 1:-1]
        if self.periodic[1]:
            q[1:-1, 0], q[1:-1, -1] = q[1:-1, -2], q[1:-1, 1]
        else:
            q[1:-1, 0], q[1:-1, -1] = q[1:-1, 1], q[1:-1, -2]

    @staticmethod
    def _neighbours(q, centre) -> np.ndarray:
        (a, b) = centre
        up = (slice(a.start + 1, a.stop + 1, a.step), b)
        down = (slice(a.start - 1, a.stop - 1, a.step), b)
        right = (a, slice(b.start + 1, b.stop + 1, b.step))
        left = (a, slice(b.start - 1, b.stop - 1, b.step))
        out = q[up] + q[down]
        out += q[right]
        out += q[left]
        return out

    def apply(self, q) -> np.ndarray:
        """A p (cells' shape) for padded p: (count p - sum of the real neighbours) / h^2."""
        self.fill_ghosts(q)
        p = q[self.inner]
        real = self._neighbours(q, self.inner) - self.self_ghosts * p
        return (self.count * p - real) / self.h ** 2

    def sweep(self, q, b, colour) -> None:
        """Gauss-Seidel on one colour's cells of padded q, in place (same-colour cells are not
        neighbours: each sub-lattice is one array update)."""
        self.fill_ghosts(q)
        h2 = self.h ** 2
        for padded, sub, count, ghosts in self.lattices[colour]:
            new = self._neighbours(q, padded) - ghosts * q[padded]
            new += h2 * b[sub]
            new /= count
            q[padded] = new

    def matrix(self) -> sp.csr_matrix:
        n = self.cells[0] * self.cells[1]
        eye = np.eye(n).reshape((n,) + self.cells)
        return sp.csr_matrix(np.stack([self.apply(self.padded(e)).ravel() for e in eye], 1))


class CellMultigrid:
    """The hierarchy of a MacGrid (all fluid); `precondition(r)` one symmetric V-cycle."""

    def __init__(self, grid, sweeps: int = 2, singular: bool = True):
        reason = multigrid_reason(grid.cells)
        if reason:
            raise ValueError(reason)
        self.sweeps, self.singular = int(sweeps), singular
        self.levels = [Level(grid.cells, grid.h, grid.periodic)]
        self.prolong = []
        while all(n % 2 == 0 and n // 2 >= MIN_COARSE for n in self.levels[-1].cells):
            fine = self.levels[-1]
            coarse = Level([n // 2 for n in fine.cells], 2 * fine.h, fine.periodic)
            self.prolong.append(sp.kron(_prolong_1d(coarse.cells[0], fine.periodic[0]),
                                        _prolong_1d(coarse.cells[1], fine.periodic[1]),
                                        format="csr"))
            self.levels.append(coarse)
        self.restrict = [(P.T / 4.0).tocsr() for P in self.prolong]
        coarsest = self.levels[-1].matrix()
        k = 1 if singular else 0
        self._lu = spla.splu(coarsest[k:, k:].tocsc())

    def _coarse_solve(self, b):
        k = 1 if self.singular else 0
        x = np.zeros(b.size)
        x[k:] = self._lu.solve(b.ravel()[k:] - (b.ravel().mean() if self.singular else 0.0))
        return x.reshape(self.levels[-1].cells)

    def _vcycle(self, k, b):
        """The correction (cells' shape) for right-hand side b at level k, from zero."""
        level = self.levels[k]
        if k == len(self.levels) - 1:
            return self._coarse_solve(b)
        q = level.padded()
        for _ in range(self.sweeps):
            level.sweep(q, b, 0)
            level.sweep(q, b, 1)
        r = b - level.apply(q)
        rc = (self.restrict[k] @ r.ravel()).reshape(self.levels[k + 1].cells)
        q[level.inner] += (self.prolong[k] @ self._vcycle(k + 1, rc).ravel()).reshape(
            level.cells)
        for _ in range(self.sweeps):
            level.sweep(q, b, 1)
            level.sweep(q, b, 0)
        return q[level.inner].copy()

    def precondition(self, r_flat) -> np.ndarray:
        z = self._vcycle(0, r_flat.reshape(self.levels[0].cells)).ravel()
        return z - z.mean() if self.singular else z

    def describe(self) -> dict:
        return {"levels": len(self.levels), "shapes": [list(lv.cells) for lv in self.levels],
                "smoother": "red-black Gauss-Seidel", "sweeps": self.sweeps, "cycle": "V",
                "prolongation": "cell-centred bilinear (3/4, 1/4)", "restriction": "P^T / 4",
                "coarse_operator": "rediscretised at each level's h (Neumann walls)",
                "coarsest": f"SuperLU of the {list(self.levels[-1].cells)} level"}


def mgpcg(A, b, x, mg: CellMultigrid, target: float, max_iterations: int):
    """Preconditioned CG on A x = b from x until ||b - A x||_2 <= target (the recurrence's
    residual; the caller checks the true one). Returns (x, iterations)."""
    r = b - A @ x
    z = mg.precondition(r)
    d = z.copy()
    rz = float(r @ z)
    for it in range(max_iterations):
        if np.linalg.norm(r) <= target:
            return x, it
        ad = A @ d
        alpha = rz / float(d @ ad)
        x = x + alpha * d
        r = r - alpha * ad
        z = mg.precondition(r)
        rz, rz_old = float(r @ z), rz
        d = z + (rz / rz_old) * d
    return x, max_iterations
