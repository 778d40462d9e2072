"""Float64 taichi kernels of the heat and wave equations on a regular 1D/2D/3D grid: the 3-, 5-
and 7-point Laplacian of `refsim.models.grid_laplacian` (Dirichlet points fixed, their rows
zero; Neumann by the mirrored ghost point, ((u_1 - 2 u_0) + u_1) / h^2; periodic wrap) and the
steps of refsim's grid_evolution group written out on it.

Layout: every field is a flat C-order float64 array (axis 0 slowest); a point's neighbours
along axis a are p -+ stride[a]. Flat indexing with runtime strides measured fastest for one
FTCS step on 1024^2 (one thread): 602 Mcell/s, against 371 for a 2D ndarray with the shape a
template and 550 for a ti.field of fixed shape (which would also recompile per shape).
A sweep of the Laplacian is two loops: the interior (rows of the last axis, no branch per
point) and the boundary (every point with an index 0 or N-1, a branch per side).

The time loop of `Sim.step(n)` runs inside one kernel, `ti.loop_config(serialize=True)`:
one launch per call (a launch per step with numpy external arrays cost ~190 us, more than
the whole step of a 33^2 grid). Inside a serial loop the sweeps are serial too, which is
what one thread (the engine's default) does anyway.
No `from __future__ import annotations` here: taichi reads annotations as objects.
"""
import numpy as np

from .kernel_types import f64, i32, ivec3, nd_f64, ti, vec3

DIRICHLET, NEUMANN, PERIODIC = 0, 1, 2
SIDE_CODE = {"dirichlet": DIRICHLET, "neumann": NEUMANN, "periodic": PERIODIC}
SET, AXPY = 0, 1  # sweep modes: dst = coef lap(src); dst = base + a (coef lap(src))

# the grid: shape and strides (unused axes 1), side kinds, 1/h^2 per axis, number of points
geo_t = ti.types.argpack(shape=ivec3, stride=ivec3, low=ivec3, high=ivec3, inv_h2=vec3,
                         size=i32)


def geometry(shape, spacing, boundary):
    """The argpack of a grid (shape up to 3 axes, C-order strides)."""
    shape = tuple(int(n) for n in shape)
    strides = [1] * len(shape)
    for axis in range(len(shape) - 2, -1, -1):
        strides[axis] = strides[axis + 1] * shape[axis + 1]
    pad = 3 - len(shape)
    size = 1
    for n in shape:
        size *= n
    return geo_t(shape=ivec3(*shape, *(1,) * pad), stride=ivec3(*strides, *(1,) * pad),
                 low=ivec3(*(SIDE_CODE[lo] for lo, _ in boundary), *(0,) * pad),
                 high=ivec3(*(SIDE_CODE[hi] for _, hi in boundary), *(0,) * pad),
                 inv_h2=vec3(*(1.0 / float(h) ** 2 for h in spacing), *(0.0,) * pad),
                 size=size)


@ti.func
def write(dst: ti.template(), base: ti.template(), p, lap, a, coef, mode: ti.template()):
    if ti.static(mode == SET):
        dst[p] = coef * lap
    else:
        dst[p] = base[p] + a * (coef * lap)



def sweeps(ndim):
    """(sweep, boundary_terms) for grids of ndim axes: sweep(dst, base, src, g, a, coef, mode)
    writes every point; boundary_terms(src, g, idx, p) -> (lap, fixed) at any point."""

    @ti.func
    def boundary_terms(src: ti.template(), g: ti.template(), idx, p):
        lap, fixed = 0.0, 0
        for ax in ti.static(range(ndim)):
            n, i, s = g.shape[ax], idx[ax], g.stride[ax]
            if (i == 0 and g.low[ax] == DIRICHLET) or (i == n - 1 and g.high[ax] == DIRICHLET):
                fixed = 1
            lo, hi = i - 1, i + 1
            if i == 0:
                lo = n - 1 if g.low[ax] == PERIODIC else 1  # Neumann: mirrored ghost u_1
            if i == n - 1:
                hi = 0 if g.high[ax] == PERIODIC else n - 2
            lap += ((src[p + (hi - i) * s] - 2.0 * src[p]) + src[p + (lo - i) * s]) * \
                g.inv_h2[ax]
        if fixed:
            lap = 0.0
        return lap, fixed

    @ti.func
    def interior(dst: ti.template(), base: ti.template(), src: ti.template(),
                 g: ti.template(), a, coef, mode: ti.template(), off: ti.template()):
        rows = 1
        for b in ti.static(range(ndim - 1)):
            rows *= g.shape[b] - 2
        last = g.shape[ndim - 1]
        shape, stride, inv_h2 = ivec3(g.shape), ivec3(g.stride), vec3(g.inv_h2)  # locals:
        for r in range(rows):  # loaded once, not once per point (measured 20 % faster)
            start, rest = 0, r
            for b in ti.static(range(ndim - 2, -1, -1)):
                m = shape[b] - 2
                start += (rest % m + 1) * stride[b]
                rest //= m
            for p in range(start + 1, start + last - 1):
                lap = 0.0
                for ax in ti.static(range(ndim)):
                    s = stride[ax]
                    lap += ((src[p + s] - 2.0 * src[p]) + src[p - s]) * inv_h2[ax]
                write(dst, base, off + p, lap, a, coef, mode)

    @ti.func
    def boundary(dst: ti.template(), base: ti.template(), src: ti.template(),
                 g: ti.template(), a, coef, mode: ti.template(), off: ti.template()):
        rows = 1
        for b in ti.static(range(ndim - 1)):
            rows *= g.shape[b]
        last = g.shape[ndim - 1]
        for r in range(rows):
            idx, start, rest, edge = ivec3(0, 0, 0), 0, r, 0
            for b in ti.static(range(ndim - 2, -1, -1)):
                i = rest % g.shape[b]
                rest //= g.shape[b]
                idx[b] = i
                start += i * g.stride[b]
                if i == 0 or i == g.shape[b] - 1:
                    edge = 1
            step = 1 if edge else last - 1  # a boundary row whole, else its two ends
            j = 0
            while j < last:
                idx[ndim - 1] = j
                lap, _ = boundary_terms(src, g, idx, start + j)
                write(dst, base, off + start + j, lap, a, coef, mode)
                j += step

    @ti.func
    def sweep(dst: ti.template(), base: ti.template(), src: ti.template(), g: ti.template(),
              a, coef, mode: ti.template(), off: ti.template()):
        interior(dst, base, src, g, a, coef, mode, off)
        boundary(dst, base, src, g, a, coef, mode, off)

    return sweep, boundary_terms


# ----- heat u' = coef lap u --------------------------------------------------------------------

def ftcs_kernel(ndim):
    """n FTCS steps u <- u + h (D lap u), alternating the buffers u -> w -> u (the caller swaps
    its two arrays when n is odd)."""
    sweep, _ = sweeps(ndim)

    @ti.kernel
    def advance(u: nd_f64, w: nd_f64, g: geo_t, h: f64, coef: f64, n: i32):
        ti.loop_config(serialize=True)
        for k in range(n):
            if k % 2 == 0:
                sweep(w, u, u, g, h, coef, AXPY, 0)
            else:
                sweep(u, w, w, g, h, coef, AXPY, 0)
    return advance


def heat_rk_kernel(ndim):
    """n steps of an explicit tableau on u' = coef lap u, refsim's FirstOrderRK arithmetic:
    y_i = u + sum_j (a_ij h) k_j over the non-zero a_ij, left to right; k_i = coef lap(y_i);
    u + sum (b_i h) k_i over the non-zero b_i. The tableau is a runtime array (`tableau_array`:
    a row-major 4 x 4, then b), the s slopes one array k of s x size: one kernel serves every
    tableau, and its one sweep compiles once."""
    sweep, _ = sweeps(ndim)

    @ti.kernel
    def advance(u: nd_f64, y: nd_f64, k: nd_f64, tab: nd_f64, s: i32, g: geo_t, h: f64,
                coef: f64, n: i32):
        npts = g.size
        ti.loop_config(serialize=True)
        for _ in range(n):
            for i in range(s):
                for p in range(npts):
                    stage = u[p]
                    for j in range(i):
                        if tab[4 * i + j] != 0.0:
                            stage = stage + (tab[4 * i + j] * h) * k[j * npts + p]
                    y[p] = stage
                sweep(k, k, y, g, 0.0, coef, SET, i * npts)
            for p in range(npts):
                value = u[p]
                for i in range(s):
                    if tab[16 + i] != 0.0:
                        value = value + (tab[16 + i] * h) * k[i * npts + p]
                u[p] = value
    return advance


def laplacian_kernel(ndim):
    """dst = base + a (coef lap src) at every point (a one-off sweep: starts, outputs,
    right-hand sides of the implicit steps)."""
    sweep, _ = sweeps(ndim)

    @ti.kernel
    def apply(dst: nd_f64, base: nd_f64, src: nd_f64, g: geo_t, a: f64, coef: f64):
        sweep(dst, base, src, g, a, coef, AXPY, 0)
    return apply


def assemble_kernel(ndim):
    """Triplets of I - c lap (rows of fixed points: the identity row) into a taichi
    SparseMatrixBuilder; Neumann's mirrored neighbour is entered twice (the builder sums)."""
    _, boundary_terms = sweeps(ndim)

    @ti.kernel
    def assemble(K: ti.types.sparse_matrix_builder(), g: geo_t, c: f64, probe: nd_f64):
        for p in range(g.size):
            idx, rest = ivec3(0, 0, 0), p
            for b in ti.static(range(ndim - 1, -1, -1)):
                idx[b] = rest % g.shape[b]
                rest //= g.shape[b]
            _, fixed = boundary_terms(probe, g, idx, p)
            K[p, p] += 1.0
            if not fixed:
                for ax in ti.static(range(ndim)):
                    n, i, s = g.shape[ax], idx[ax], g.stride[ax]
                    lo, hi = i - 1, i + 1
                    if i == 0:
                        lo = n - 1 if g.low[ax] == PERIODIC else 1
                    if i == n - 1:
                        hi = 0 if g.high[ax] == PERIODIC else n - 2
                    K[p, p] += 2.0 * c * g.inv_h2[ax]
                    K[p, p + (hi - i) * s] += -c * g.inv_h2[ax]
                    K[p, p + (lo - i) * s] += -c * g.inv_h2[ax]
    return assemble


# ----- wave u'' = coef lap u, state (x, v) ----------------------------------------------------

def wave_kernel(ndim, name):
    """n steps of symplectic Euler (kick-drift), Stormer-Verlet (summed form: d += h^2 a(x),
    x += d; `aux` holds d) or velocity Verlet (`aux` holds the carried a), refsim's
    arithmetic. Arguments (x, v, aux, g, h, coef, n)."""
    sweep, _ = sweeps(ndim)

    @ti.kernel
    def symplectic_euler(x: nd_f64, v: nd_f64, aux: nd_f64, g: geo_t, h: f64, coef: f64,
                         n: i32):
        ti.loop_config(serialize=True)
        for _ in range(n):
            sweep(v, v, x, g, h, coef, AXPY, 0)  # v + h (c^2 lap x)
            for p in range(g.size):
                x[p] = x[p] + h * v[p]

    @ti.kernel
    def stormer_verlet(x: nd_f64, v: nd_f64, aux: nd_f64, g: geo_t, h: f64, coef: f64,
                       n: i32):
        ti.loop_config(serialize=True)
        for _ in range(n):
            sweep(aux, aux, x, g, h * h, coef, AXPY, 0)  # d + h^2 (c^2 lap x)
            for p in range(g.size):
                x[p] = x[p] + aux[p]

    @ti.kernel
    def velocity_verlet(x: nd_f64, v: nd_f64, aux: nd_f64, g: geo_t, h: f64, coef: f64,
                        n: i32):
        ti.loop_config(serialize=True)
        for _ in range(n):
            for p in range(g.size):
                vh = v[p] + (0.5 * h) * aux[p]
                v[p] = vh
                x[p] = x[p] + h * vh
            sweep(aux, aux, x, g, 0.0, coef, SET, 0)
            for p in range(g.size):
                v[p] = v[p] + (0.5 * h) * aux[p]

    return {"symplectic_euler": symplectic_euler, "stormer_verlet": stormer_verlet,
            "velocity_verlet": velocity_verlet}[name]


def wave_rk_kernel(ndim):
    """n steps of an explicit tableau on (x, v)' = (v, coef lap x), refsim's ExplicitRK
    arithmetic: X_i = x + sum_j (a_ij h) V_j, V_i = v + sum_j (a_ij h) A_j over the non-zero
    a_ij (V_1 = v), A_i = coef lap(X_i); x + sum (b_i h) V_i, v + sum (b_i h) A_i. The tableau
    a runtime array as in `heat_rk_kernel`; V_i and A_i in arrays of s x size, X_i in y."""
    sweep, _ = sweeps(ndim)

    @ti.kernel
    def advance(x: nd_f64, v: nd_f64, y: nd_f64, rates: nd_f64, slopes: nd_f64, tab: nd_f64,
                s: i32, g: geo_t, h: f64, coef: f64, n: i32):
        npts = g.size
        ti.loop_config(serialize=True)
        for _ in range(n):
            for i in range(s):
                for p in range(npts):
                    xi, vi = x[p], v[p]
                    for j in range(i):
                        if tab[4 * i + j] != 0.0:
                            haij = tab[4 * i + j] * h
                            xi = xi + haij * rates[j * npts + p]
                            vi = vi + haij * slopes[j * npts + p]
                    y[p] = xi
                    rates[i * npts + p] = vi
                sweep(slopes, slopes, y, g, 0.0, coef, SET, i * npts)
            for p in range(npts):
                xs, vs = x[p], v[p]
                for i in range(s):
                    if tab[16 + i] != 0.0:
                        hbi = tab[16 + i] * h
                        xs = xs + hbi * rates[i * npts + p]
                        vs = vs + hbi * slopes[i * npts + p]
                x[p] = xs
                v[p] = vs
    return advance


def tableau_array(tableau):
    """An explicit tableau (at most 4 stages) as the RK kernels read it: a (4 x 4 row-major,
    zero-padded) then b (4): (array, stages)."""
    a, b, _ = tableau.arrays()
    s = len(b)
    if s > 4:
        raise ValueError(f"tableau stages must be at most 4 for the grid kernels, got {s}")
    out = np.zeros(20)
    out[:16].reshape(4, 4)[:s, :s] = a
    out[16:16 + s] = b
    return out, s


# ----- right-hand sides and updates around a sparse solve (one launch each per step) ---------

def implicit_kernels(ndim):
    """(rhs, update) kernels of the implicit steps, refsim's sparse_linear arithmetic:
    heat Crank-Nicolson rhs = u + (h/2) (D lap u) (mode 0); wave implicit Euler rhs =
    x + h v, then v + h (c^2 lap x1) (mode 1); implicit midpoint rhs = (x + h v) + (h^2/4) ax
    with ax = c^2 lap x kept in `ax`, then v + (h/2) (ax + c^2 lap x1) (mode 2)."""
    sweep, _ = sweeps(ndim)

    @ti.kernel
    def rhs(out: nd_f64, x: nd_f64, v: nd_f64, ax: nd_f64, g: geo_t, h: f64, coef: f64,
            mode: i32):
        if mode == 0:
            sweep(out, x, x, g, 0.5 * h, coef, AXPY, 0)
        elif mode == 1:
            for p in range(g.size):
                out[p] = x[p] + h * v[p]
        else:
            sweep(ax, ax, x, g, 0.0, coef, SET, 0)
            for p in range(g.size):
                out[p] = (x[p] + h * v[p]) + (0.25 * h * h) * ax[p]

    @ti.kernel
    def update(v: nd_f64, x1: nd_f64, ax: nd_f64, a1: nd_f64, g: geo_t, h: f64, coef: f64,
               mode: i32):
        if mode == 1:
            sweep(v, v, x1, g, h, coef, AXPY, 0)
        else:
            sweep(a1, a1, x1, g, 0.0, coef, SET, 0)
            for p in range(g.size):
                v[p] = v[p] + (0.5 * h) * (ax[p] + a1[p])

    return rhs, update
