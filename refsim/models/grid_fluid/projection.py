"""The pressure projection on the MAC grid: (D G) p = D u* / dt, then u = u* - dt G p.

The unknowns are the FLUID cells' kinematic pressures (p / rho, m^2/s^2). A face is ACTIVE
(its velocity is changed by the projection) when it is not a wall face, not the duplicate last
face of a periodic axis, touches no SOLID cell and at least one FLUID cell; every other face
keeps its velocity (walls: 0; solids: 0). AIR cells have p = 0 (the free surface, Dirichlet).
G (active faces x fluid cells, scipy.sparse CSR, pattern built once per grid and marks):
+1/h at the cell above/right of the face, -1/h at the one below/left (an AIR neighbour gives
no entry, its p being 0). On the fluid cells D = -G^T over the active faces, so
D (u* - dt G p) = 0 is A p = b with A = G^T G (symmetric positive semi-definite: -(D G), the
5-point Laplacian in the interior, homogeneous Neumann at walls and solids) and
b = -D u* / dt; after the solve the projected field has D u = 0 to the solver's tolerance
(|D u| <= ||b - A p|| dt, cell by cell).

Null space: with no AIR cell (walls, periodic axes) A's kernel is the constant, and b's
mean over the cells is zero up to round-off (the boundary flux vanishes); b's mean is removed
(the compatible right-hand side) and the solution's mean fixed to zero afterwards.

Solvers (`METHODS` for every grid, `ALL_METHODS` adds "multigrid"; the criterion of
refsim.models.poisson_solvers: ||b - A p||_2 <=
rtol ||b||_2 on the TRUE residual, restarting from the iterate at most MAX_RESTARTS times):
- "direct": SuperLU (the same symmetric-mode options as poisson_solvers.SUPERLU_OPTIONS) of
  A, with the first fluid cell's pressure pinned to 0 when singular (the reduced matrix is
  SPD; the pinned row then holds by the zero sum of the others), factorised once per grid;
- "cg": scipy.sparse.linalg.cg on A (consistent semi-definite system: the Krylov space stays
  in A's range), no preconditioner;
- "pyamg": pyamg.smoothed_aggregation_solver with CG acceleration on A, pinned as for
  "direct" where singular (on the singular A itself its CG stopped on an "indefinite
  preconditioner" above the target); its hierarchy built once per grid.
- "multigrid": CG preconditioned by one symmetric V-cycle of an in-house cell-centred
  geometric multigrid (refsim.models.grid_fluid.projection_mg: MGPCG), for grids of fluid
  cells only with even cell counts; hierarchy built once per grid.
Why not refsim.models.poisson_solvers directly: its problems are vertex-centred with every
side Dirichlet (PoissonProblem takes a `Grid` and its free points), and its geometric
multigrid coarsens 2^k + 1 vertex grids; the MAC pressure is cell-centred, Neumann or
periodic, singular. The SuperLU options, the iteration caps and the true-residual criterion
are theirs (imported).
"""
from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from refsim.models.poisson_solvers import MAX_CYCLES, MAX_RESTARTS, SUPERLU_OPTIONS
from refsim.scene.fluid_grid import AIR, FLUID, SOLID

from .mac import MacGrid, divergence
from .projection_mg import CellMultigrid, mgpcg, multigrid_reason

METHODS = ("direct", "cg", "pyamg")  # for every grid, marks included
MULTIGRID = "multigrid"  # fluid cells only, even counts (projection_mg.multigrid_reason)
ALL_METHODS = METHODS + (MULTIGRID,)
SOLVER_TEXT = {
    "direct": "scipy.sparse.linalg.splu (SuperLU) of A = G^T G, symmetric mode, MMD_AT_PLUS_A "
              "ordering; one cell pinned where A is singular; factorised once per grid",
    "cg": "scipy.sparse.linalg.cg on A = G^T G (semi-definite, consistent rhs), no "
          "preconditioner",
    "pyamg": "pyamg.smoothed_aggregation_solver(A, one cell pinned where singular).solve(r, "
             "accel='cg') on the residual, hierarchy built once per grid",
    "multigrid": "in-house cell-centred geometric multigrid as CG's preconditioner (MGPCG, "
                 "refsim.models.grid_fluid.projection_mg), hierarchy built once per grid",
}


def _face_cells(grid: MacGrid):
    """Per face (u faces then v faces, C order): (low cell, high cell) flat indices (-1 outside
    the grid) and whether the face is a wall face or a periodic duplicate."""
    nx, ny = grid.cells
    cell = np.arange(nx * ny).reshape(nx, ny)
    out = []
    for axis, (n, shape) in enumerate(((nx, (nx + 1, ny)), (ny, (nx, ny + 1)))):
        k = np.arange(n + 1)
        low_k, high_k = k - 1, k.copy()
        if grid.periodic[axis]:
            low_k[0] = n - 1
        valid_low, valid_high = (low_k >= 0) & (low_k < n), (high_k < n)
        idx = np.indices(shape)
        along, other = idx[axis], idx[1 - axis]
        lo_k, hi_k = low_k[along], high_k[along]
        if axis == 0:
            lo = np.where(valid_low[along], cell[np.clip(lo_k, 0, n - 1), other], -1)
            hi = np.where(valid_high[along], cell[np.clip(hi_k, 0, n - 1), other], -1)
        else:
            lo = np.where(valid_low[along], cell[other, np.clip(lo_k, 0, n - 1)], -1)
            hi = np.where(valid_high[along], cell[other, np.clip(hi_k, 0, n - 1)], -1)
        fixed = (along == n) if grid.periodic[axis] else (along == 0) | (along == n)
        out.append((lo.ravel(), hi.ravel(), fixed.ravel()))
    return [np.concatenate(parts) for parts in zip(*out)]


class PressureSystem:
    """G, A = G^T G and the solver state for one grid and its cell marks (None: all fluid)."""

    def __init__(self, grid: MacGrid, marks=None):
        self.grid = grid
        nx, ny = grid.cells
        marks = np.full((nx, ny), FLUID, np.int8) if marks is None else np.asarray(marks)
        self.marks = marks
        flat = marks.ravel()
        self.fluid = flat == FLUID
        lo, hi, fixed = _face_cells(grid)
        kind_lo = np.where(lo >= 0, flat[np.maximum(lo, 0)], SOLID)
        kind_hi = np.where(hi >= 0, flat[np.maximum(hi, 0)], SOLID)
        self.active = ~fixed & (kind_lo != SOLID) & (kind_hi != SOLID) & \
            ((kind_lo == FLUID) | (kind_hi == FLUID))
        self.n_u = (nx + 1) * ny
        column = np.full(nx * ny, -1)
        column[self.fluid] = np.arange(int(self.fluid.sum()))
        rows, cols, vals = [], [], []
        face = np.flatnonzero(self.active)
        for cells, sign in ((hi, 1.0), (lo, -1.0)):
            c = cells[face]
            keep = (c >= 0) & (column[np.maximum(c, 0)] >= 0)
            rows.append(np.flatnonzero(keep))
            cols.append(column[c[keep]])
            vals.append(np.full(int(keep.sum()), sign / grid.h))
        self.G = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows),
                                                       np.concatenate(cols))),
                               shape=(face.size, int(self.fluid.sum())))
        self.face_index = face
        self.A = (self.G.T @ self.G).tocsr()
        self.singular = not np.any(marks == AIR)
        self._cache = {}

    # -- operators on the whole field ----------------------------------------------------------
    def split(self, faces):
        nx, ny = self.grid.cells
        return faces[:self.n_u].reshape(nx + 1, ny), faces[self.n_u:].reshape(nx, ny + 1)

    def rhs(self, u, v, dt):
        """b = -D u* / dt on the fluid cells, its mean removed where A is singular."""
        b = -divergence(u, v, self.grid.h).ravel()[self.fluid] / dt
        return b - b.mean() if self.singular else b

    def subtract_gradient(self, u, v, p_fluid, dt):
        """u - dt G p on the active faces (new arrays); periodic duplicates copied."""
        faces = np.concatenate([np.ravel(u), np.ravel(v)])
        faces[self.face_index] -= dt * (self.G @ p_fluid)
        un, vn = self.split(faces)
        if self.grid.periodic[0]:
            un[-1] = un[0]
        if self.grid.periodic[1]:
            vn[:, -1] = vn[:, 0]
        return un, vn

    def pressure_field(self, p_fluid) -> np.ndarray:
        p = np.zeros(self.fluid.size)
        p[self.fluid] = p_fluid
        return p.reshape(self.grid.cells)

    # -- solvers -------------------------------------------------------------------------------
    def solve(self, b, method="direct", rtol=1e-10):
        """(p on the fluid cells, info {iterations, residual, setup_s, solve_s, method})."""
        if method not in ALL_METHODS:
            raise ValueError(f"projection method must be one of {list(ALL_METHODS)}, got "
                             f"{method!r}")
        t0 = time.perf_counter()
        norm_b = float(np.linalg.norm(b))
        if norm_b == 0.0:
            return np.zeros_like(b), {"iterations": 0, "residual": 0.0, "setup_s": 0.0,
                                      "solve_s": 0.0, "method": method}
        target = rtol * norm_b
        once, setup = getattr(self, f"_{method}")(b, target)
        t1 = time.perf_counter()
        x, iterations = np.zeros_like(b), 0
        for _ in range(MAX_RESTARTS + 1):
            x, done = once(x)
            iterations += done
            if np.linalg.norm(b - self.A @ x) <= target:
                break
        if self.singular:
            x -= x.mean()
        residual = float(np.linalg.norm(b - self.A @ x)) / norm_b
        return x, {"iterations": int(iterations), "residual": residual,
                   "setup_s": setup + (t1 - t0), "solve_s": time.perf_counter() - t1,
                   "method": method}

    def _direct(self, b, target):
        if "lu" not in self._cache:
            self._cache["lu"] = spla.splu(self._reduced().tocsc(), **SUPERLU_OPTIONS)
        lu = self._cache["lu"]

        def once(x):
            r = b - self.A @ x
            dx = np.zeros_like(x)
            if self.singular:
                dx[1:] = lu.solve(r[1:])
            else:
                dx = lu.solve(r)
            return x + dx, 1
        return once, 0.0

    def _cg(self, b, target):
        count = [0]

        def once(x):
            count[0] = 0
            x, _ = spla.cg(self.A, b, x0=x, rtol=target / float(np.linalg.norm(b)), atol=0.0,
                           maxiter=20 * len(b),
                           callback=lambda xk: count.__setitem__(0, count[0] + 1))
            return x, count[0]
        return once, 0.0

    def _reduced(self):
        """A with the first cell pinned where singular (SPD), else A."""
        return self.A[1:, 1:] if self.singular else self.A

    def _pyamg(self, b, target):
        if "amg" not in self._cache:
            import pyamg
            self._cache["amg"] = pyamg.smoothed_aggregation_solver(self._reduced().tocsr())
        amg, k = self._cache["amg"], (1 if self.singular else 0)

        def once(x):
            residuals = []
            r = b - self.A @ x
            dx = np.zeros_like(x)
            dx[k:] = amg.solve(r[k:], x0=np.zeros(r.size - k), accel="cg",
                               tol=target / max(float(np.linalg.norm(r[k:])), 1e-300),
                               maxiter=MAX_CYCLES, residuals=residuals)
            return x + dx, len(residuals) - 1
        return once, 0.0

    def _multigrid(self, b, target):
        if "mg" not in self._cache:
            reason = multigrid_reason(self.grid.cells, self.marks)
            if reason:
                raise ValueError(reason)
            self._cache["mg"] = CellMultigrid(self.grid, singular=self.singular)
        mg = self._cache["mg"]
        return (lambda x: mgpcg(self.A, b, x, mg, target, MAX_CYCLES)), 0.0

    def project(self, u, v, dt, method="direct", rtol=1e-10):
        """(u, v, p, info): the projected face velocities, the kinematic pressure (nx, ny; 0
        outside the fluid) and the solve's info plus "divergence" (max |D u| over fluid cells
        after the projection)."""
        p, info = self.solve(self.rhs(u, v, dt), method, rtol)
        un, vn = self.subtract_gradient(u, v, p, dt)
        div = divergence(un, vn, self.grid.h).ravel()[self.fluid]
        info["divergence"] = float(np.max(np.abs(div))) if div.size else 0.0
        return un, vn, self.pressure_field(p), info

    def describe(self, method: str, rtol: float) -> dict:
        return {"method": method, "solver_text": SOLVER_TEXT[method], "rtol": rtol,
                "criterion": "||b - A p||_2 <= rtol ||b||_2 on the true residual (restarts "
                             "from the iterate where a recurrence drifted)",
                "matrix": "A = G^T G = -(D G) on the fluid cells (5-point Laplacian inside, "
                          "Neumann at walls/solids, p = 0 in air), scipy.sparse CSR",
                "unknowns": int(self.fluid.sum()), "active_faces": int(self.active.sum()),
                "null_space": "constant: rhs mean removed, solution mean fixed to 0"
                              if self.singular else "none (air cells give p = 0)"}
