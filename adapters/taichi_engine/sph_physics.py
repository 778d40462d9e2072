"""2D WCSPH (`refsim.models.sph`'s model and parameters) as taichi functions: the Wendland C2
kernel, Tait's equation of state, the neighbour grid, and the rates each particle gathers.

Particles: fluid 0..n_fluid-1, then the fixed wall (dummy) particles, in one position and one
velocity array (walls at rest, v = 0). Neighbours: a uniform grid over the bounding box of all
particles, cell >= 2h, rebuilt after every drift by a serial counting sort (ids in index order
within a cell); each particle gathers its own sums over the 3 x 3 cells around it (every sum is
written by its owner: no atomics, no scatter). Pairs are those with r < 2h, i != j; the
expressions follow the numpy model term by term, so the two engines differ in summation order
only. `S` is the SPH argpack (sph_kernels.sph_t).
No `from __future__ import annotations` here: taichi reads `ti.template()` annotations as objects.
"""
import math

from refsim.models.sph import GAMMA as SPH_GAMMA

from .kernel_types import f64, i32, ivec2, ti, vec2

pi = math.pi


# -- model: refsim.models.sph, written with the same operation order ----------------------
@ti.func
def wendland(r, h):
    q = r / h
    return 7.0 / (4.0 * pi * h * h) * ti.pow(ti.max(1.0 - 0.5 * q, 0.0), 4.0) * (1.0 + 2.0 * q)


@ti.func
def gradient_factor(r, h):
    """F with grad_i W_ij = F (x_i - x_j)."""
    q = r / h
    return -5.0 * 7.0 / (4.0 * pi * h * h) * ti.pow(ti.max(1.0 - 0.5 * q, 0.0), 3.0) / (h * h)


@ti.func
def tait_pressure(S: ti.template(), rho):
    return S.rho0 * S.c0 * S.c0 / SPH_GAMMA * (ti.pow(rho / S.rho0, SPH_GAMMA) - 1.0)


@ti.func
def tait_density(S: ti.template(), p):
    return S.rho0 * ti.pow(ti.max(1.0 + p * SPH_GAMMA / (S.rho0 * S.c0 * S.c0), 1e-6),
                           1.0 / SPH_GAMMA)


# -- neighbours: uniform grid, serial counting sort ----------------------------------------
@ti.func
def build_grid(x: ti.template(), S: ti.template()):
    """Bounding box of all particles, cell >= S.cell_min (enlarged until the grid fits the
    cell arrays), counting sort: S.order lists particle ids cell by cell (index order in a
    cell), cell k holds S.order[cell_start[k]:cell_count[k]]; S.cell_of[i] is i's cell.
    A non-finite coordinate leaves no grid (dims 0: no pairs) and is counted in stats[0]."""
    lo, hi = vec2(1e308, 1e308), vec2(-1e308, -1e308)
    ok = 1
    for i in range(x.shape[0]):
        lo, hi = ti.min(lo, x[i]), ti.max(hi, x[i])
        if not (ti.abs(x[i]) < 1e300).all():
            ok = 0
    ext = hi - lo
    for k in ti.static(range(2)):
        if not ext[k] < 1e300:
            ok = 0
    c, dims = S.cell_min, ivec2(0, 0)
    if ok:
        cap = ti.cast(S.cell_count.shape[0], f64)
        nf = ti.floor(ext / c) + 1.0
        while nf[0] * nf[1] > cap:
            c *= ti.max(1.05, ti.sqrt(nf[0] * nf[1] / cap))
            nf = ti.floor(ext / c) + 1.0
        dims = ti.cast(nf, i32)
        total = dims[0] * dims[1]
        for k in range(total):
            S.cell_count[k] = 0
        for i in range(x.shape[0]):
            q = ti.min(ti.cast(ti.floor((x[i] - lo) / c), i32), dims - 1)
            cell = q[1] * dims[0] + q[0]
            S.cell_of[i] = cell
            S.cell_count[cell] += 1
        running = 0
        for k in range(total):
            S.cell_start[k] = running
            running += S.cell_count[k]
            S.cell_count[k] = S.cell_start[k]  # the fill pointer, then the cell's end
        for i in range(x.shape[0]):
            cell = S.cell_of[i]
            S.order[S.cell_count[cell]] = i
            S.cell_count[cell] += 1
    else:
        S.stats[0] += 1
    S.grid[0], S.grid[1], S.grid[2] = lo[0], lo[1], c
    S.dims[0], S.dims[1] = dims[0], dims[1]


@ti.func
def row_span(S: ti.template(), i, dy):
    """Ids S.order[s0:s1]: the cells x-1..x+1 of row y+dy around particle i's cell (cells
    of a row are contiguous in S.order). Empty without a grid."""
    s0, s1 = 0, 0
    nx, ny = S.dims[0], S.dims[1]
    if nx > 0:
        cell = S.cell_of[i]
        qx, qy = cell % nx, cell // nx + dy
        if 0 <= qy < ny:
            row = qy * nx
            s0 = S.cell_start[row + ti.max(qx - 1, 0)]
            s1 = S.cell_count[row + ti.min(qx + 1, nx - 1)]
    return s0, s1


# -- rates, each gathered by its owner -----------------------------------------------------
@ti.func
def density_rates(x: ti.template(), v: ti.template(), S: ti.template(), i,
                  diffuse: ti.template()):
    """(continuity, delta-SPH diffusion) of particle i in one gather over its neighbours:
    d rho_i/dt = sum_j m (v_i - v_j) . grad_i W_ij (walls at rest), and (when `diffuse`
    and delta > 0) the diffusion with the hydrostatic part taken out, fluid-fluid:
    sum_j 2 delta h c0 m |F_ij| (rho_j - rho_i - rho^H_ji) / rho_j, rho^H_ji =
    rho0 ((1 - 7 g . (x_i - x_j) / c0^2)^(1/7) - 1) (0 without `diffuse`)."""
    reach = 2.0 * S.h
    g = S.gravity
    rate, diffused = 0.0, 0.0
    for dy in range(-1, 2):
        s0, s1 = row_span(S, i, dy)
        for s in range(s0, s1):
            j = S.order[s]
            if j != i:
                d = x[i] - x[j]
                r = ti.sqrt(d[0] * d[0] + d[1] * d[1])
                if r < reach:
                    grad = gradient_factor(r, S.h) * d
                    dv = v[i] - v[j]
                    rate += S.mass * (dv[0] * grad[0] + dv[1] * grad[1])
                    if ti.static(diffuse):
                        if S.delta != 0.0 and j < S.n_fluid:
                            weight = -2.0 * S.delta * S.h * S.c0 * S.mass * (
                                grad[0] * d[0] + grad[1] * d[1]) / (r * r)
                            head = SPH_GAMMA * (d[0] * g[0] + d[1] * g[1]) / (S.c0 * S.c0)
                            down = S.rho0 * (ti.pow(1.0 - head, 1.0 / SPH_GAMMA) - 1.0)
                            diffused += weight * (S.rho[j] - S.rho[i] - down) / S.rho[j]
    return rate, diffused


@ti.func
def fluid_pressure(S: ti.template(), i):
    """Tait; clamped at 0 unless the fluid may carry tension."""
    p = tait_pressure(S, S.rho[i])
    if S.tension == 0:
        p = ti.max(p, 0.0)
    return p


@ti.func
def pressures(x: ti.template(), S: ti.template()):
    """Fluid: p = Tait(rho) (clamped at 0 without tension). Walls (Adami 2012, eq. 27,
    wall at rest):
    p_w = max((sum p_f W + sum rho_f ((x_w - x_f) . g) W) / sum W, 0) (0 without fluid
    neighbours), rho_w from the inverted equation of state."""
    for i in range(S.n_fluid):
        S.p[i] = fluid_pressure(S, i)
    for w in range(S.n_fluid, x.shape[0]):
        wall_pressure(x, S, w)


@ti.func
def wall_pressure(x: ti.template(), S: ti.template(), w):
    """Adami's extrapolated pressure and the matching density of wall particle w."""
    n = S.n_fluid
    reach = 2.0 * S.h
    g = S.gravity
    total, num_p, num_g = 0.0, 0.0, 0.0
    for dy in range(-1, 2):
        s0, s1 = row_span(S, w, dy)
        for s in range(s0, s1):
            f = S.order[s]
            if f < n:
                dw = x[w] - x[f]
                r = ti.sqrt(dw[0] * dw[0] + dw[1] * dw[1])
                if r < reach:
                    weight = wendland(r, S.h)
                    total += weight
                    num_p += S.p[f] * weight
                    num_g += S.rho[f] * (dw[0] * g[0] + dw[1] * g[1]) * weight
    pw = 0.0
    if total > 0.0:
        pw = (num_p + num_g) / total
    pw = ti.max(pw, 0.0)
    S.p[w] = pw
    S.rho[w] = tait_density(S, pw)


@ti.func
def momentum(x: ti.template(), v: ti.template(), S: ti.template(), i):
    """dv_i/dt = -sum_j m (p_i/rho_i^2 + p_j/rho_j^2 + Pi_ij) grad_i W_ij + g, Monaghan's
    Pi_ij = -alpha c0 mu_ij / rho_ij for approaching pairs, mu_ij = h v_ij.x_ij /
    (r^2 + 0.01 h^2), rho_ij the mean density."""
    reach = 2.0 * S.h
    out = vec2(0.0, 0.0)
    pi_term = S.p[i] / (S.rho[i] * S.rho[i])
    for dy in range(-1, 2):
        s0, s1 = row_span(S, i, dy)
        for s in range(s0, s1):
            j = S.order[s]
            if j != i:
                d = x[i] - x[j]
                r = ti.sqrt(d[0] * d[0] + d[1] * d[1])
                if r < reach:
                    grad = gradient_factor(r, S.h) * d
                    dv = v[i] - v[j]
                    vr = dv[0] * d[0] + dv[1] * d[1]
                    visc = 0.0
                    if vr < 0.0 and (S.no_slip != 0 or j < S.n_fluid):
                        mu = S.h * vr / (r * r + 0.01 * S.h * S.h)
                        visc = -S.alpha * S.c0 * mu / (0.5 * (S.rho[i] + S.rho[j]))
                    coef = S.mass * (pi_term + S.p[j] / (S.rho[j] * S.rho[j]) + visc)
                    out += -coef * grad
    return out + S.gravity


@ti.func
def accelerations(x: ti.template(), v: ti.template(), S: ti.template()):
    pressures(x, S)
    for i in range(S.n_fluid):
        S.acc[i] = momentum(x, v, S, i)
