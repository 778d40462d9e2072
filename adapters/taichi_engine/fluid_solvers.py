"""taichi's sparse solves of the MAC fluid step: the pressure projection (A p = b, A = G^T G on
the fluid cells) and the implicit viscous step ((I - dt nu M) u = u* + dt nu c per face
component), each a matrix assembled by a float64 kernel into ti.linalg.SparseMatrixBuilder and
factorised by ti.linalg.SparseSolver (LDLT: Eigen's SimplicialLDLT with AMD ordering; both
matrices are symmetric positive definite once the pressure's null space is pinned), the
pattern analysed and the matrix factorised once per Sim.

Projection, as refsim.models.grid_fluid.projection.PressureSystem's "direct" solver:
- unknowns the FLUID cells in C order; a face is active when it is not a wall face nor a
  periodic axis' duplicate last face, touches no SOLID cell and at least one FLUID cell; AIR
  cells hold p = 0 (no unknown);
- without AIR the matrix is singular (the constant): the rhs' mean is removed, the first fluid
  cell pinned (its row and column dropped: the reduced matrix is SPD), the solution's mean
  set to 0 after the solve;
- the stopping rule is refsim's: ||b - A p||_2 <= rtol ||b||_2 on the true residual (A p by
  the matrix-free kernel `apply_pressure`), the solve repeated on the residual (iterative
  refinement) at most MAX_RESTARTS times.
Two solvers (the group's formulations):
- "direct" (the default): LDLT converges to round-off in one solve whatever the marks (free
  surface, solids) and its factorisation is reused every step, as refsim's SuperLU is; the two
  differ only by the factorisations' round-off, well inside the solver tolerance;
- "mgpcg": CG preconditioned by a cell-centred multigrid V-cycle (fluid_multigrid), for
  all-fluid grids of even cell counts: O(cells) per solve where the factorisation's fill and
  setup grow faster (the benchmark's 1024^2), equal to the others to the solver tolerance.
The Python side: numpy for the setup (masks, unknown numbering), the unknown vectors handed to
SparseSolver.solve, their norms and means (refsim's criterion, O(cells) glue per solve).
"""
from __future__ import annotations

import numpy as np

from refsim.models.poisson_solvers import MAX_RESTARTS
from refsim.scene.fluid_grid import AIR, FLUID, SOLID

SOLVER_TEXT = {
    "direct": "A = G^T G on the fluid cells (5-point, Neumann at walls and solids, p = 0 in "
              "air) assembled by a float64 kernel into ti.linalg.SparseMatrixBuilder, "
              "ti.linalg.SparseSolver LDLT (Eigen SimplicialLDLT, AMD), first fluid cell "
              "pinned where singular; analysed and factorised once per Sim",
    "mgpcg": "CG on A = G^T G (matrix-free kernel) preconditioned by one symmetric V-cycle of a "
             "cell-centred geometric multigrid (float64 kernels; fluid_multigrid), hierarchy "
             "built once per Sim"}
VISCOSITY_TEXT = ("backward Euler: (I - dt nu M) u = u* + dt nu c per face component, "
                  "assembled by a float64 kernel, ti.linalg.SparseSolver LDLT, factorised once "
                  "per Sim")


MIN_COARSE = 4  # cells per axis on the multigrid's coarsest level


def multigrid_reason(cells, marks) -> str | None:
    """Why mgpcg (fluid_multigrid) does not take a grid, None if it does (here, free of
    taichi, so that listing the formulations does not initialise it)."""
    if marks is not None and np.any(np.asarray(marks) != FLUID):
        return "taichi mgpcg: grids of fluid cells only (no air or solid marks)"
    if any(n % 2 or n < 2 * MIN_COARSE for n in cells):
        return (f"taichi mgpcg: cells per axis even and at least {2 * MIN_COARSE}, got "
                f"{tuple(cells)}")
    return None


def active_faces(marks, periodic):
    """(au (nx + 1, ny), av (nx, ny + 1)) int32: 1 where the projection moves the face."""
    nx, ny = marks.shape
    out = []
    for axis, n in ((0, nx), (1, ny)):
        pad = [(0, 0), (0, 0)]
        pad[axis] = (1, 1)
        kinds = np.pad(marks, pad, constant_values=SOLID)  # beyond a wall: nothing
        if periodic[axis]:  # face 0's low cell is the last cell
            first, last = [slice(None)] * 2, [slice(None)] * 2
            first[axis], last[axis] = 0, n
            kinds[tuple(first)] = np.take(marks, n - 1, axis=axis)
        lo = np.take(kinds, np.arange(n + 1), axis=axis)
        hi = np.take(kinds, np.arange(1, n + 2), axis=axis)
        active = (lo != SOLID) & (hi != SOLID) & ((lo == FLUID) | (hi == FLUID))
        fixed = [slice(None)] * 2
        fixed[axis] = n  # the last face: a wall or a periodic duplicate
        active[tuple(fixed)] = False
        if not periodic[axis]:
            fixed[axis] = 0
            active[tuple(fixed)] = False
        out.append(active.astype(np.int32))
    return out[0], out[1]


class PressureSolver:
    """The projection's matrix, factorisation and solve for one grid and its marks."""

    def __init__(self, fk, geo, nx, ny, h, periodic, marks, method="direct"):
        from .runtime import runtime
        ti = runtime()["ti"]
        self.fk, self.geo, self.h, self.method = fk, geo, float(h), method
        marks = np.zeros((nx, ny), np.int8) if marks is None else np.asarray(marks)
        self.fluid = np.ascontiguousarray(marks == FLUID, dtype=np.int32)
        self.fluid_flat = self.fluid.ravel().astype(bool)
        self.au, self.av = active_faces(marks, periodic)
        self.singular = not np.any(marks == AIR)
        self.size = int(self.fluid_flat.sum())
        pin = 1 if self.singular else 0
        column = np.full(nx * ny, -1, np.int32)
        column[self.fluid_flat] = np.arange(self.size, dtype=np.int32) - pin
        column[column < 0] = -1
        inv_h = 1.0 / self.h
        self.w = inv_h * inv_h  # refsim's entries: (1/h) (1/h) per face
        reduced = self.size - pin
        self.p = np.zeros((nx, ny))
        self.ap = np.zeros((nx, ny))
        self.b = np.zeros((nx, ny))
        self.reduced = reduced
        self.solver = self.mg = None
        if reduced == 0:
            return
        if method == "mgpcg":
            from .fluid_multigrid import CellMultigrid
            reason = multigrid_reason((nx, ny), marks)
            if reason:
                raise ValueError(reason)
            self.mg = CellMultigrid(fk, nx, ny, h, periodic, MIN_COARSE)
            return
        builder = ti.linalg.SparseMatrixBuilder(reduced, reduced, dtype=ti.f64,
                                                max_num_triplets=4 * 2 * (nx + 1) * (ny + 1))
        fk.assemble_pressure(builder, column.reshape(nx, ny), self.au, self.av, self.w)
        matrix = builder.build()
        self.solver = ti.linalg.SparseSolver(dtype=ti.f64, solver_type="LDLT", ordering="AMD")
        self.solver.analyze_pattern(matrix)
        self.solver.factorize(matrix)
        if not self.solver.info():
            raise ValueError("taichi SparseSolver LDLT could not factorise the pressure "
                             "matrix")

    def residual(self, x, b):
        """b - A x on the unknowns (A x by the kernel)."""
        self.p.ravel()[self.fluid_flat] = x
        self.fk.apply_pressure(self.p, self.ap, self.au, self.av, self.fluid, self.geo, self.w)
        return b - self.ap.ravel()[self.fluid_flat]

    def apply(self, p):
        """A p on a whole (nx, ny) array (a new array)."""
        out = np.zeros_like(p)
        self.fk.apply_pressure(p, out, self.au, self.av, self.fluid, self.geo, self.w)
        return out

    def solve(self, b, rtol):
        """(p on the fluid cells, iterations, relative residual)."""
        norm_b = float(np.linalg.norm(b))
        if norm_b == 0.0 or (self.solver is None and self.mg is None):
            return np.zeros_like(b), 0, 0.0
        if self.mg is not None:
            return self._mgpcg(b, rtol * norm_b, norm_b)
        target, pin = rtol * norm_b, 1 if self.singular else 0
        x, iterations = np.zeros_like(b), 0
        for _ in range(MAX_RESTARTS + 1):
            r = self.residual(x, b)
            if iterations and np.linalg.norm(r) <= target:
                break
            dx = np.asarray(self.solver.solve(np.ascontiguousarray(r[pin:])), np.float64)
            x = x.copy()
            x[pin:] += dx
            iterations += 1
        if self.singular:
            x -= x.mean()
        return x, iterations, float(np.linalg.norm(self.residual(x, b))) / norm_b

    def _mgpcg(self, b, target, norm_b):
        from .fluid_multigrid import mgpcg
        b2 = np.ascontiguousarray(b.reshape(self.p.shape))
        x, iterations = np.zeros_like(b2), 0
        for _ in range(MAX_RESTARTS + 1):
            x, done = mgpcg(self.apply, self.mg, b2, x, target)
            iterations += done
            if np.linalg.norm(b2 - self.apply(x)) <= target:
                break
        x -= x.mean()
        residual = float(np.linalg.norm(b2 - self.apply(x))) / norm_b
        return x.ravel(), iterations, residual

    def project(self, u, v, dt, rtol):
        """In place: u, v projected; returns (p (nx, ny), iterations, residual, divergence)."""
        fk = self.fk
        fk.rhs(u, v, self.b, self.geo, float(dt))
        b = self.b.ravel()[self.fluid_flat]
        if self.singular:
            b = b - b.mean()
        x, iterations, residual = self.solve(b, rtol)
        p = np.zeros_like(self.p)
        p.ravel()[self.fluid_flat] = x
        fk.subtract_gradient(u, v, p, self.au, self.av, self.geo, float(dt))
        divergence = fk.max_divergence(u, v, self.fluid, self.geo)
        return p, iterations, residual, float(divergence)


class ImplicitViscosity:
    """(I - dt nu M) per face component ("u" staggered along x, "v" along y), factorised once."""

    def __init__(self, nx, ny, h, periodic, lid, dt, nu):
        from . import fluid_viscosity_kernels as vk
        from .runtime import runtime
        ti = runtime()["ti"]
        self.parts = []
        c = float(dt) * float(nu)
        for axis, top in ((0, float(lid)), (1, 0.0)):
            moving = tuple(slice(0, n) if periodic[a] else
                           (slice(1, n) if a == axis else slice(0, n))
                           for a, n in enumerate((nx, ny)))
            shape = tuple(s.stop - s.start for s in moving)
            size = shape[0] * shape[1]
            h2 = float(h) ** 2
            const = np.zeros(shape)  # refsim's c: 2 w / h^2 on the rows beside the lid
            if axis == 0 and not periodic[1]:
                const[:, -1] = (0.0 + 2.0 * top) / h2
            builder = ti.linalg.SparseMatrixBuilder(size, size, dtype=ti.f64,
                                                    max_num_triplets=5 * size)
            vk.assemble_viscous(builder, shape[0], shape[1], axis, int(periodic[0]),
                                int(periodic[1]), c, h2)
            solver = ti.linalg.SparseSolver(dtype=ti.f64, solver_type="LDLT", ordering="AMD")
            matrix = builder.build()
            solver.analyze_pattern(matrix)
            solver.factorize(matrix)
            if not solver.info():
                raise ValueError("taichi SparseSolver LDLT could not factorise I - dt nu M")
            self.parts.append((moving, solver, c * const.ravel()))

    def step(self, u, v):
        """In place on the moving faces of u and v."""
        for a, (moving, solver, rhs_const) in zip((u, v), self.parts):
            x = np.ravel(a[moving]) + rhs_const
            new = np.asarray(solver.solve(np.ascontiguousarray(x)), np.float64)
            a[moving] = new.reshape(a[moving].shape)
