"""taichi's MGPCG for the MAC pressure (formulation "mgpcg"): conjugate gradient on A = G^T G
preconditioned by one symmetric V-cycle of a cell-centred geometric multigrid (McAdams,
Sifakis & Teran 2010), float64 kernels, the design of refsim's in-house "multigrid" solver:
- levels: the fine cells, then both counts halved (h doubled) while both are even and at least
  2 MIN_COARSE; every level rediscretises A (5-point; a wall's missing neighbour dropped from
  the row: Neumann; periodic axes wrap);
- smoother: red-black Gauss-Seidel (colour = parity of i + j), `SWEEPS` pre-sweeps red then
  black, post-sweeps black then red (the adjoint order);
- prolongation: cell-centred bilinear (1D weights 3/4 and 1/4 from the two nearest coarse
  cells; beyond a wall the edge cell, periodic wraps); restriction its transpose over 4 (the
  V-cycle is then symmetric, as CG's preconditioner must be);
- coarsest level: ti.linalg.SparseSolver LDLT of its matrix, the first cell pinned (A is
  singular: walls or periodic, no air), the rhs' mean removed; the cycle's output has its
  mean removed so that CG stays in A's range.
Grids of FLUID cells only (no air or solid marks: they change the operator level by level),
even cell counts of at least 2 MIN_COARSE per axis (`multigrid_reason`). The stopping rule is
refsim's: the recurrence's residual to rtol ||b||, then the true residual checked (by the
`apply_pressure` kernel) and CG restarted from the iterate where it is above, at most
MAX_RESTARTS times; at most MAX_CYCLES iterations a start.
No `from __future__ import annotations` here: taichi reads annotations as objects.
"""
import numpy as np

from refsim.models.poisson_solvers import MAX_CYCLES

from .fluid_kernels import grid_t
from .kernel_types import f64, i32, ti

SWEEPS = 2


@ti.func
def _wrap(k: i32, n: i32, periodic: i32) -> i32:
    """k on an axis of n entries (k within one entry of it): wrapped when periodic, clamped
    (the edge cell) otherwise."""
    out = k
    if k < 0:
        out = n - 1 if periodic else 0
    elif k >= n:
        out = 0 if periodic else n - 1
    return out


@ti.func
def _real_neighbours(p: ti.template(), i: i32, j: i32, px: i32, py: i32):
    """(sum, count) of the cell's real neighbours (walls: missing; periodic: wrapped)."""
    nx, ny = p.shape[0], p.shape[1]
    total, count = 0.0, 0
    if 0 < i < nx - 1 and 0 < j < ny - 1:  # interior: no branch per neighbour (same order)
        total = p[i - 1, j] + p[i + 1, j] + p[i, j - 1] + p[i, j + 1]
        count = 4
    else:
        for d in ti.static(((-1, 0), (1, 0), (0, -1), (0, 1))):
            a, b = i + d[0], j + d[1]
            ok = 0 <= a < nx and 0 <= b < ny
            if ti.static(d[0] != 0):
                ok = ok or px != 0
            else:
                ok = ok or py != 0
            if ok:
                total += p[_wrap(a, nx, 1), _wrap(b, ny, 1)]
                count += 1
    return total, count


# Every kernel loops over rows (i) in parallel and along each row (j) serially: a grouped loop
# over both axes splits its flat index by a division per point (~4x slower, poisson_kernels),
# and a reduction keeps a row's partial sum in a local before adding it to the total.
@ti.kernel
def mg_sweep(p: grid_t, b: grid_t, colour: i32, px: i32, py: i32, h2: f64):
    """Gauss-Seidel on the cells of one colour: p = (neighbours + h^2 b) / count."""
    for i in range(p.shape[0]):
        first = (i + colour) % 2
        for k in range((p.shape[1] - first + 1) // 2):
            j = first + 2 * k
            total, count = _real_neighbours(p, i, j, px, py)
            p[i, j] = (total + h2 * b[i, j]) / count


@ti.kernel
def mg_residual(p: grid_t, b: grid_t, r: grid_t, px: i32, py: i32, inv_h2: f64):
    """r = b - A p, A p = (count p - neighbours) / h^2."""
    for i in range(p.shape[0]):
        for j in range(p.shape[1]):
            total, count = _real_neighbours(p, i, j, px, py)
            r[i, j] = b[i, j] - (count * p[i, j] - total) * inv_h2


@ti.kernel
def mg_restrict(r: grid_t, bc: grid_t, px: i32, py: i32):
    """bc = P^T r / 4: coarse I collects fine 2I and 2I + 1 at 3/4, 2I - 1 and 2I + 2 at 1/4
    (clamped to the edge fine cell at a wall, wrapped where periodic)."""
    nx, ny = r.shape[0], r.shape[1]
    for I in range(bc.shape[0]):
        for J in range(bc.shape[1]):
            acc = 0.0
            for a in ti.static(range(4)):
                fa = _wrap(2 * I - 1 + a, nx, px)
                wa = 0.75 if ti.static(a == 1 or a == 2) else 0.25
                row = 0.0
                for c in ti.static(range(4)):
                    wc = 0.75 if ti.static(c == 1 or c == 2) else 0.25
                    row += wc * r[fa, _wrap(2 * J - 1 + c, ny, py)]
                acc += wa * row
            bc[I, J] = 0.25 * acc


@ti.kernel
def mg_prolong_add(z: grid_t, zc: grid_t, px: i32, py: i32):
    """z += P zc: fine i from coarse i // 2 at 3/4 and its neighbour on i's side at 1/4."""
    nx, ny = zc.shape[0], zc.shape[1]
    for i in range(z.shape[0]):
        I = i // 2
        I2 = _wrap(I + (-1 if i % 2 == 0 else 1), nx, px)
        for j in range(z.shape[1]):
            J = j // 2
            J2 = _wrap(J + (-1 if j % 2 == 0 else 1), ny, py)
            z[i, j] += (0.75 * (0.75 * zc[I, J] + 0.25 * zc[I, J2])
                        + 0.25 * (0.75 * zc[I2, J] + 0.25 * zc[I2, J2]))


@ti.kernel
def fill(a: grid_t, value: f64):
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            a[i, j] = value


@ti.kernel
def dot(a: grid_t, b: grid_t) -> f64:
    total = 0.0
    for i in range(a.shape[0]):
        row = 0.0
        for j in range(a.shape[1]):
            row += a[i, j] * b[i, j]
        total += row
    return total


@ti.kernel
def axpy(y: grid_t, a: f64, x: grid_t):
    """y += a x."""
    for i in range(y.shape[0]):
        for j in range(y.shape[1]):
            y[i, j] += a * x[i, j]


@ti.kernel
def xpay(y: grid_t, a: f64, x: grid_t):
    """y = x + a y."""
    for i in range(y.shape[0]):
        for j in range(y.shape[1]):
            y[i, j] = x[i, j] + a * y[i, j]


class CellMultigrid:
    """The hierarchy of an all-fluid grid and its V-cycle (numpy arrays per level, handed to
    the kernels as external arrays)."""

    def __init__(self, fk, nx, ny, h, periodic, min_coarse):
        """min_coarse: the coarsest level's cells per axis at least (fluid_solvers.MIN_COARSE,
        which also says which grids the hierarchy takes)."""
        from .runtime import runtime
        ti_ = runtime()["ti"]
        self.px, self.py = int(periodic[0]), int(periodic[1])
        shapes, hs = [(nx, ny)], [float(h)]
        while all(n % 2 == 0 and n // 2 >= min_coarse for n in shapes[-1]):
            shapes.append((shapes[-1][0] // 2, shapes[-1][1] // 2))
            hs.append(2 * hs[-1])
        self.shapes, self.hs = shapes, hs
        self.p = [np.zeros(s) for s in shapes]
        self.b = [np.zeros(s) for s in shapes]
        self.r = [np.zeros(s) for s in shapes]
        cnx, cny = shapes[-1]
        size = cnx * cny
        column = (np.arange(size, dtype=np.int32) - 1).reshape(cnx, cny)  # cell 0 pinned
        au = np.ones((cnx + 1, cny), np.int32)
        av = np.ones((cnx, cny + 1), np.int32)
        au[-1] = 0
        av[:, -1] = 0
        if not self.px:
            au[0] = 0
        if not self.py:
            av[:, 0] = 0
        inv_h = 1.0 / hs[-1]
        builder = ti_.linalg.SparseMatrixBuilder(size - 1, size - 1, dtype=ti_.f64,
                                                 max_num_triplets=8 * size)
        fk.assemble_pressure(builder, column, au, av, inv_h * inv_h)
        self.coarse = ti_.linalg.SparseSolver(dtype=ti_.f64, solver_type="LDLT",
                                              ordering="AMD")
        matrix = builder.build()
        self.coarse.analyze_pattern(matrix)
        self.coarse.factorize(matrix)

    def _vcycle(self, k, p, b):
        """p = the cycle's approximation of A_k^-1 b."""
        if k == len(self.shapes) - 1:
            rhs = b.ravel()
            x = np.zeros(rhs.size)
            x[1:] = np.asarray(self.coarse.solve(np.ascontiguousarray(rhs[1:] - rhs.mean())),
                               np.float64)
            p[...] = x.reshape(self.shapes[k])
            return
        h2, r = self.hs[k] ** 2, self.r[k]
        fill(p, 0.0)
        for _ in range(SWEEPS):
            mg_sweep(p, b, 0, self.px, self.py, h2)
            mg_sweep(p, b, 1, self.px, self.py, h2)
        mg_residual(p, b, r, self.px, self.py, 1.0 / h2)
        mg_restrict(r, self.b[k + 1], self.px, self.py)
        self._vcycle(k + 1, self.p[k + 1], self.b[k + 1])
        mg_prolong_add(p, self.p[k + 1], self.px, self.py)
        for _ in range(SWEEPS):
            mg_sweep(p, b, 1, self.px, self.py, h2)
            mg_sweep(p, b, 0, self.px, self.py, h2)

    def precondition(self, r, z):
        """z = M r ((nx, ny) numpy arrays), its mean removed."""
        self._vcycle(0, z, r)
        z -= z.mean()

    def describe(self) -> dict:
        return {"levels": len(self.shapes), "shapes": [list(s) for s in self.shapes],
                "smoother": f"red-black Gauss-Seidel, V({SWEEPS}, {SWEEPS}), post-sweeps in "
                            "the adjoint order", "prolongation": "cell-centred bilinear "
                            "(3/4, 1/4)", "restriction": "P^T / 4",
                "coarse_operator": "rediscretised at each level's h",
                "coarsest": f"SparseSolver LDLT of the {list(self.shapes[-1])} level, "
                            "first cell pinned"}


def mgpcg(apply, mg, b, x, target):
    """CG on A x = b (A x = apply(x), (nx, ny) numpy arrays) preconditioned by mg, from x
    (updated in place), until the recurrence's ||r|| <= target; (x, iterations)."""
    r = b - apply(x)
    z = np.zeros_like(r)
    mg.precondition(r, z)
    d = z.copy()
    rz = dot(r, z)
    for it in range(MAX_CYCLES):
        if np.sqrt(dot(r, r)) <= target:
            return x, it
        ad = apply(d)
        alpha = rz / dot(d, ad)
        axpy(x, alpha, d)
        axpy(r, -alpha, ad)
        mg.precondition(r, z)
        rz, rz_old = dot(r, z), rz
        xpay(d, rz / rz_old, z)
    return x, MAX_CYCLES
