"""The 5-point (2D) / 7-point (3D) Poisson problem as float64 taichi kernels: the pieces of a
matrix-free conjugate gradient and of a geometric multigrid V- or W-cycle (its preconditioner).

Sign: the kernels solve A x = b with A = -L_h (symmetric positive definite on the free points)
and b = -f, so that CG's denominators p.Ap are positive; the residual b - A u is -(f - L_h u),
of the same norm. Every array is a d-dimensional taichi ndarray of the grid's shape; only the
free (interior) points are read as unknowns or written: boundary entries of the CG vectors
and of the multigrid corrections stay zero (so the stencil applied to them is the operator
restricted to the free points), the solution's boundary entries keep the Dirichlet values.

(A x)_I = sum_k w_k (2 x_I - x_{I+e_k} - x_{I-e_k}),  w_k = 1 / h_k^2.

Multigrid pieces (vertex-centred: level l+1 holds every other point of level l, J <-> 2J):
- red-black Gauss-Seidel: points of colour c = (sum_k I_k) mod 2 updated in place,
  x_I = (b_I + sum_k w_k (x_{I+e_k} + x_{I-e_k})) / sum_k 2 w_k;
- damped Jacobi: x += omega (b - A x) / diag (the residual kernel, then `add_scaled`);
- restriction by full weighting, b_c[J] = sum_{o in {-1,0,1}^d} prod_k (2 - |o_k|) / 4
  r[2J + o]: exactly P^T / 2^d of the prolongation P below (what keeps the cycle symmetric);
- prolongation by d-linear interpolation, x_f[I] += sum over the 2^d coarse corners of
  prod_k weight_k x_c[J]: weight 1 on an axis where I_k is even (J_k = I_k / 2, one corner),
  1/2 for each of the two corners where I_k is odd.
Reductions (dot products) are returned by the kernels (taichi's reduction of a scalar in a
parallel loop: on one thread a serial sum in index order, reproducible).
Drivers (Python loops over CG iterations and multigrid levels only, every grid operation a
kernel): `PoissonSolver` (CG, or CG with z = M r by `Multigrid`, one cycle per iteration) and
`Multigrid` (V or W cycle on the level arrays; level 0's right-hand side is CG's r and its
correction CG's z, so the cycle copies nothing).
No `from __future__ import annotations` here: taichi reads annotations as objects.
"""
import math

from .kernel_types import f64, ti
from .runtime import runtime


def poisson_kernels(d: int) -> dict:
    """The kernels for d = 2 or 3 (made once per process; taichi compiles them on first use)."""
    if d not in (2, 3):
        raise ValueError(f"poisson kernels: d must be 2 or 3, got {d}")
    made = runtime()["kernels"]  # the runtime's per-process cache, as kernel_store's kernels
    if ("grid_poisson", d) not in made:
        made[("grid_poisson", d)] = _make(d)
    return made[("grid_poisson", d)]


def _make(d: int) -> dict:
    grid_t = ti.types.ndarray(dtype=f64, ndim=d)
    weights_t = ti.types.vector(d, f64)
    stencil = _stencil_funcs(d)
    return {"weights_t": weights_t, **_cg_kernels(d, grid_t, weights_t, stencil),
            **_multigrid_kernels(d, grid_t, weights_t, stencil)}


def _stencil_funcs(d: int) -> dict:
    """point(O, j): the index of row O (the first d - 1 axes), column j (the last axis); the
    stencil sums at a point. The kernels loop over rows in parallel (ti.grouped over the
    first d - 1 axes) and along each row serially: ~4x faster than one grouped loop over all
    axes, whose flat index is split by a division per axis (taichi 1.7.4, measured on 1025^2)."""

    @ti.func
    def point(O, j):
        return ti.Vector([O[k] if k < d - 1 else j for k in ti.static(range(d))])

    @ti.func
    def minus_laplacian(x: ti.template(), I, w):
        acc = 0.0
        for k in ti.static(range(d)):
            e = ti.Vector.unit(d, k, ti.i32)
            acc += w[k] * (2.0 * x[I] - x[I + e] - x[I - e])
        return acc

    @ti.func
    def neighbour_sum(x: ti.template(), I, w):
        acc = 0.0
        for k in ti.static(range(d)):
            e = ti.Vector.unit(d, k, ti.i32)
            acc += w[k] * (x[I + e] + x[I - e])
        return acc

    return {"point": point, "minus_laplacian": minus_laplacian,
            "neighbour_sum": neighbour_sum}


# The free points of array `a`: rows O over the first d - 1 axes (parallel), j along the last
# (serial); every kernel below spells it out (taichi needs the loop header inside the kernel).
def _cg_kernels(d: int, grid_t, weights_t, stencil) -> dict:
    point, minus_laplacian = stencil["point"], stencil["minus_laplacian"]

    @ti.kernel
    def dot(a: grid_t, b: grid_t) -> f64:
        total = 0.0
        for O in ti.grouped(ti.ndrange(*[(1, a.shape[k] - 1) for k in ti.static(range(d - 1))])):
            row = 0.0
            for j in range(1, a.shape[d - 1] - 1):
                row += a[point(O, j)] * b[point(O, j)]
            total += row
        return total

    @ti.kernel
    def start_residual(u: grid_t, f: grid_t, r: grid_t, w: weights_t) -> f64:
        """r = b - A u = -f - A u on the free points (u's boundary values as data); r.r."""
        total = 0.0
        for O in ti.grouped(ti.ndrange(*[(1, u.shape[k] - 1) for k in ti.static(range(d - 1))])):
            row = 0.0
            for j in range(1, u.shape[d - 1] - 1):
                I = point(O, j)
                r[I] = -f[I] - minus_laplacian(u, I, w)
                row += r[I] * r[I]
            total += row
        return total

    @ti.kernel
    def apply_dot(p: grid_t, q: grid_t, w: weights_t) -> f64:
        """q = A p on the free points; returns p.q."""
        total = 0.0
        for O in ti.grouped(ti.ndrange(*[(1, p.shape[k] - 1) for k in ti.static(range(d - 1))])):
            row = 0.0
            for j in range(1, p.shape[d - 1] - 1):
                I = point(O, j)
                q[I] = minus_laplacian(p, I, w)
                row += p[I] * q[I]
            total += row
        return total

    @ti.kernel
    def update_solution(u: grid_t, r: grid_t, p: grid_t, q: grid_t, alpha: f64) -> f64:
        """u += alpha p, r -= alpha q on the free points; returns the new r.r."""
        total = 0.0
        for O in ti.grouped(ti.ndrange(*[(1, u.shape[k] - 1) for k in ti.static(range(d - 1))])):
            row = 0.0
            for j in range(1, u.shape[d - 1] - 1):
                I = point(O, j)
                u[I] += alpha * p[I]
                r[I] -= alpha * q[I]
                row += r[I] * r[I]
            total += row
        return total

    @ti.kernel
    def update_direction(p: grid_t, z: grid_t, beta: f64):
        """p = z + beta p on the free points."""
        for O in ti.grouped(ti.ndrange(*[(1, p.shape[k] - 1) for k in ti.static(range(d - 1))])):
            for j in range(1, p.shape[d - 1] - 1):
                I = point(O, j)
                p[I] = z[I] + beta * p[I]

    return {"dot": dot, "start_residual": start_residual,
            "apply_dot": apply_dot, "update_solution": update_solution,
            "update_direction": update_direction}


def _multigrid_kernels(d: int, grid_t, weights_t, stencil) -> dict:
    point, minus_laplacian = stencil["point"], stencil["minus_laplacian"]
    neighbour_sum = stencil["neighbour_sum"]

    @ti.kernel
    def zero(x: grid_t):
        """x = 0 on the free points (the boundary entries of corrections stay 0)."""
        for O in ti.grouped(ti.ndrange(*[(1, x.shape[k] - 1) for k in ti.static(range(d - 1))])):
            for j in range(1, x.shape[d - 1] - 1):
                x[point(O, j)] = 0.0

    @ti.kernel
    def gauss_seidel(x: grid_t, b: grid_t, w: weights_t, colour: ti.i32):
        """One half sweep: the free points with (sum_k I_k) mod 2 == colour, in place (each
        row's points of that colour: j = first, first + 2, ...)."""
        diagonal = 0.0
        for k in ti.static(range(d)):
            diagonal += 2.0 * w[k]
        for O in ti.grouped(ti.ndrange(*[(1, x.shape[k] - 1) for k in ti.static(range(d - 1))])):
            first = 1 + (colour + 1 + O.sum()) % 2  # (O.sum() + first) % 2 == colour
            for m in range(max(0, (x.shape[d - 1] - 2 - first) // 2 + 1)):
                I = point(O, first + 2 * m)
                x[I] = (b[I] + neighbour_sum(x, I, w)) / diagonal

    @ti.kernel
    def residual(x: grid_t, b: grid_t, res: grid_t, w: weights_t):
        """res = b - A x on the free points."""
        for O in ti.grouped(ti.ndrange(*[(1, x.shape[k] - 1) for k in ti.static(range(d - 1))])):
            for j in range(1, x.shape[d - 1] - 1):
                I = point(O, j)
                res[I] = b[I] - minus_laplacian(x, I, w)

    @ti.kernel
    def add_scaled(x: grid_t, res: grid_t, scale: f64):
        """x += scale res on the free points (damped Jacobi: scale = omega / diag)."""
        for O in ti.grouped(ti.ndrange(*[(1, x.shape[k] - 1) for k in ti.static(range(d - 1))])):
            for j in range(1, x.shape[d - 1] - 1):
                I = point(O, j)
                x[I] += scale * res[I]

    return {"zero": zero, "gauss_seidel": gauss_seidel, "residual": residual,
            "add_scaled": add_scaled, **_transfer_kernels(d, grid_t, point)}


def _transfer_kernels(d: int, grid_t, point) -> dict:
    @ti.kernel
    def restrict(fine: grid_t, coarse: grid_t):
        """coarse = full weighting of fine, on the coarse free points."""
        for O in ti.grouped(ti.ndrange(*[(1, coarse.shape[k] - 1)
                                         for k in ti.static(range(d - 1))])):
            for j in range(1, coarse.shape[d - 1] - 1):
                J = point(O, j)
                acc = 0.0
                for o in ti.static(ti.grouped(ti.ndrange(*([(-1, 2)] * d)))):
                    weight = 1.0
                    for k in ti.static(range(d)):
                        weight *= (2.0 - abs(o[k])) * 0.25
                    acc += weight * fine[2 * J + o]
                coarse[J] = acc

    @ti.kernel
    def prolong_add(coarse: grid_t, fine: grid_t):
        """fine += d-linear interpolation of coarse, on the fine free points."""
        for O in ti.grouped(ti.ndrange(*[(1, fine.shape[k] - 1)
                                         for k in ti.static(range(d - 1))])):
            for j in range(1, fine.shape[d - 1] - 1):
                I = point(O, j)
                acc = 0.0
                for c in ti.static(ti.grouped(ti.ndrange(*([(0, 2)] * d)))):
                    weight = 1.0
                    J = I // 2
                    for k in ti.static(range(d)):
                        odd = I[k] % 2
                        J[k] += c[k] * odd
                        if odd == 1:
                            weight *= 0.5
                        elif c[k] == 1:
                            weight = 0.0
                    if weight != 0.0:
                        acc += weight * coarse[J]
                fine[I] += acc

    return {"restrict": restrict, "prolong_add": prolong_add}


MAX_RESTARTS = 3  # CG restarts from the true residual before the solve is declared failed


class PoissonSolver:
    """CG (options None) or multigrid-preconditioned CG on one grid, arrays made once.

    shape, spacing: the grid; f: the right-hand side (the grid's shape); options: the
    resolved multigrid options (levels, smoother, sweeps, cycle, coarse_sweeps) with
    `shapes` the level shapes, finest first. `solve(u0, rtol, cap)` -> (iterations, relative
    residual) from the initial guess u0."""

    def __init__(self, shape, spacing, f, options=None, shapes=()):
        import numpy as np
        d = len(shape)
        self.kernels = k = poisson_kernels(d)
        self.weights = np.array([1.0 / h ** 2 for h in spacing])
        self.w = k["weights_t"](self.weights.tolist())
        self.u, self.f, self.r, self.p, self.q = (_grid_array(shape) for _ in range(5))
        self.f.from_numpy(np.ascontiguousarray(f, dtype=np.float64))
        self.z = self.r if options is None else _grid_array(shape)
        self.multigrid = None if options is None else Multigrid(k, self.weights, options,
                                                                shapes, self.z, self.r)
        self.f_norm = math.sqrt(k["dot"](self.f, self.f))
        self.start_norm, self.reference = 0.0, 1.0

    def start(self, u0):
        """u = u0, r = b - A u0; (0, relative residual of u0)."""
        self.u.from_numpy(_contiguous(u0))
        self.start_norm = math.sqrt(self.kernels["start_residual"](self.u, self.f, self.r,
                                                                   self.w))
        self.reference = self.f_norm if self.f_norm > 0 else (self.start_norm or 1.0)
        return 0, self.start_norm / self.reference

    def start_ratio(self, rtol):
        """||r_k|| / ||r_0|| that the target rtol asks for (1 when r_0 = 0)."""
        return rtol * self.reference / self.start_norm if self.start_norm > 0 else 1.0

    def solve(self, u0, rtol, cap):
        """CG runs until the recursive residual meets rtol; the true residual is then
        recomputed and CG restarted from the current u while it is above (at most
        MAX_RESTARTS times, `cap` iterations in all)."""
        k = self.kernels
        iterations, norm = 0, self.start(u0)[1] * self.reference
        target = rtol * self.reference
        for _ in range(MAX_RESTARTS + 1):
            if norm <= target or iterations >= cap:
                break
            iterations += self._run(target * target, cap - iterations)
            norm = math.sqrt(k["start_residual"](self.u, self.f, self.r, self.w))
        return iterations, norm / self.reference

    def _precondition(self, rr):
        """z = M r and r.z (plain CG: z is r, r.z = rr)."""
        if self.multigrid is None:
            return rr
        self.multigrid.apply()
        return self.kernels["dot"](self.r, self.z)

    def _run(self, target2, budget):
        """CG iterations from the current r (= b - A u) until r.r <= target2 or `budget`
        iterations; returns the iterations done."""
        k = self.kernels
        rz = self._precondition(k["dot"](self.r, self.r))
        k["update_direction"](self.p, self.z, 0.0)
        for done in range(1, budget + 1):
            pq = k["apply_dot"](self.p, self.q, self.w)
            if not pq > 0.0:  # p = 0 (r = 0 exactly) or a breakdown: nothing more to gain
                return done
            rr = k["update_solution"](self.u, self.r, self.p, self.q, rz / pq)
            if rr <= target2:
                return done
            rz_new = self._precondition(rr)
            k["update_direction"](self.p, self.z, rz_new / rz)
            rz = rz_new
        return budget

    def solution(self):
        return self.u.to_numpy()


class Multigrid:
    """One multigrid cycle z = M r on the level hierarchy (level 0 the CG's own z and r)."""

    def __init__(self, kernels, weights, options, shapes, z, r):
        self.k, self.o = kernels, options
        self.levels = len(shapes)
        self.w = [kernels["weights_t"]((weights / 4.0 ** level).tolist())
                  for level in range(self.levels)]
        self.diagonal = [2.0 * float(sum(weights)) / 4.0 ** level
                         for level in range(self.levels)]
        self.x = [z] + [_grid_array(s) for s in shapes[1:]]
        self.b = [r] + [_grid_array(s) for s in shapes[1:]]
        self.res = [_grid_array(s) for s in shapes]
        d = len(shapes[0])
        self.omega = 2.0 * d / (2.0 * d + 1.0)
        self.gamma = 1 if options.cycle == "V" else 2

    def apply(self):
        self._cycle(0, True)

    def _cycle(self, level, zero_start):
        k, x, b = self.k, self.x[level], self.b[level]
        if zero_start:
            k["zero"](x)
        if level == self.levels - 1:
            self._gauss_seidel(level, self.o.coarse_sweeps, (0, 1))
            self._gauss_seidel(level, self.o.coarse_sweeps, (1, 0))
            return
        self._smooth(level, (0, 1))
        k["residual"](x, b, self.res[level], self.w[level])
        k["restrict"](self.res[level], self.b[level + 1])
        for visit in range(self.gamma):
            self._cycle(level + 1, visit == 0)
        k["prolong_add"](self.x[level + 1], x)
        self._smooth(level, (1, 0))

    def _smooth(self, level, colours):
        if self.o.smoother == "rbgs":
            self._gauss_seidel(level, self.o.sweeps, colours)
            return
        k, x = self.k, self.x[level]
        for _ in range(self.o.sweeps):
            k["residual"](x, self.b[level], self.res[level], self.w[level])
            k["add_scaled"](x, self.res[level], self.omega / self.diagonal[level])

    def _gauss_seidel(self, level, sweeps, colours):
        k, x, b, w = self.k, self.x[level], self.b[level], self.w[level]
        for _ in range(sweeps):
            for colour in colours:
                k["gauss_seidel"](x, b, w, colour)


def _grid_array(shape):
    out = ti.ndarray(f64, tuple(shape))
    out.fill(0.0)
    return out


def _contiguous(arr):
    import numpy as np
    return np.ascontiguousarray(arr, dtype=np.float64)
