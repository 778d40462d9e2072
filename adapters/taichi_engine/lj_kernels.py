"""Lennard-Jones particles as float64 taichi kernels: the model of refsim.models.lennard_jones
(12-6 pairs within the cut-off, optionally shifted; all pairs when the cut-off is inf), open
space or a periodic box (minimum image on the first `dim` axes), state as vec3 (a 2D scene has
z = 0 and a single cell along z).

Neighbours: a uniform grid rebuilt at every force evaluation by a serial counting sort (cells of
side >= r_c: L / floor(L / r_c) on periodic axes, the bounding box over r_c-sized cells, enlarged
to fit the cell arrays, on open ones); each particle gathers the forces of the particles in its
cell and the adjacent ones (3 per axis; a periodic axis of 2 cells visits its other cell once,
of 1 cell only its own), so it writes only its own sum: no atomics, and F_ij = -F_ji bit for bit
(r^2 of -d equals r^2 of d; the minimum image is odd in d).
Steppers (the time loop inside the kernel, serialised), one kernel for all, the stepper a runtime
argument (so one force evaluation is inlined and compiled once per process): velocity Verlet
(carried acceleration, `start` computes a(x0)), symplectic Euler (kick then drift, refsim's
SymplecticEulerKD), explicit Euler and classical RK4 (stage sums accumulated as b_k-weighted
vectors).
No `from __future__ import annotations` here: taichi reads annotations as objects.
"""
from .kernel_types import f64, i32, nd_f64, nd_i32, nd_vec3, ti, vec3

lj_t = ti.types.argpack(
    eps=f64, sigma=f64, cutoff=f64, all_pairs=i32, periodic=i32, dim=i32,
    box=vec3, inv_mass=nd_f64, acc=nd_vec3, xs=nd_vec3, vs=nd_vec3, sx=nd_vec3, sv=nd_vec3,
    cell_start=nd_i32, cell_end=nd_i32, cell_of=nd_i32, order=nd_i32, grid=nd_f64,
    dims=nd_i32)


@ti.func
def _is_periodic(P: ti.template(), k):
    return P.periodic == 1 and k < P.dim


@ti.func
def build_grid(x: ti.template(), P: ti.template()):
    """Per axis origin (grid[k]), side (grid[3 + k]) and cell count (dims[k]); counting sort:
    cell c holds order[cell_start[c]:cell_end[c]] (index order), cell_of[i] is i's cell."""
    lo, hi = vec3(1e308, 1e308, 1e308), vec3(-1e308, -1e308, -1e308)
    for i in range(x.shape[0]):
        lo, hi = ti.min(lo, x[i]), ti.max(hi, x[i])
    cap = ti.cast(P.cell_start.shape[0], f64)
    side, dims = vec3(P.cutoff, P.cutoff, P.cutoff), vec3(1.0, 1.0, 1.0)
    for _ in range(64):  # enlarge open cells until the grid fits (a few rounds at most)
        for k in ti.static(range(3)):
            if _is_periodic(P, k):
                dims[k] = ti.max(ti.floor(P.box[k] / P.cutoff), 1.0)
                side[k], lo[k] = P.box[k] / dims[k], 0.0
            else:
                dims[k] = ti.max(ti.floor((hi[k] - lo[k]) / side[k]), 1.0)
        if dims[0] * dims[1] * dims[2] <= cap:
            break
        for k in ti.static(range(3)):
            if not _is_periodic(P, k):
                side[k] *= 1.5
    for k in ti.static(range(3)):
        if not _is_periodic(P, k):
            side[k] = ti.max((hi[k] - lo[k]) / dims[k], 1e-300)
        P.grid[k], P.grid[3 + k], P.dims[k] = lo[k], side[k], ti.cast(dims[k], i32)
    total = P.dims[0] * P.dims[1] * P.dims[2]
    for c in range(total):
        P.cell_end[c] = 0
    for i in range(x.shape[0]):
        q = cell_coords(x, P, i)
        cell = (q[2] * P.dims[1] + q[1]) * P.dims[0] + q[0]
        P.cell_of[i] = cell
        P.cell_end[cell] += 1
    running = 0
    for c in range(total):
        P.cell_start[c] = running
        running += P.cell_end[c]
        P.cell_end[c] = P.cell_start[c]  # the fill pointer, then the cell's end
    for i in range(x.shape[0]):
        cell = P.cell_of[i]
        P.order[P.cell_end[cell]] = i
        P.cell_end[cell] += 1


@ti.func
def cell_coords(x: ti.template(), P: ti.template(), i):
    q = ti.Vector([0, 0, 0])
    for k in ti.static(range(3)):
        y = x[i][k]
        if _is_periodic(P, k):
            y -= P.box[k] * ti.floor(y / P.box[k])
        q[k] = ti.min(ti.max(ti.cast(ti.floor((y - P.grid[k]) / P.grid[3 + k]), i32), 0),
                      P.dims[k] - 1)
    return q


@ti.func
def pair_force(x: ti.template(), P: ti.template(), i, j):
    """g (x_j - x_i) with g = -U'(r)/r, minus taken by the caller: the force on j from i."""
    d = x[j] - x[i]
    for k in ti.static(range(3)):
        if _is_periodic(P, k):
            d[k] -= P.box[k] * ti.round(d[k] / P.box[k])
    r2 = d.dot(d)
    out = vec3(0.0, 0.0, 0.0)
    if r2 < P.cutoff * P.cutoff:
        s2 = P.sigma * P.sigma / r2
        s6 = s2 * s2 * s2
        out = (24.0 * P.eps * (2.0 * s6 * s6 - s6) / r2) * d
    return out


@ti.func
def _neighbour_cell(P: ti.template(), q, o):
    """The cell at offset o from cell q, -1 when outside an open axis or a repeat modulo a
    periodic axis of fewer than 3 cells."""
    cell, ok = 0, True
    for kk in ti.static(range(3)):
        k = 2 - kk  # z, y, x: (z dims_y + y) dims_x + x
        c = q[k] + o[k]
        n = P.dims[k]
        if _is_periodic(P, k):
            if (n == 1 and o[k] != 0) or (n == 2 and o[k] == -1):
                ok = False
            c = (c + n) % n
        elif c < 0 or c >= n:
            ok = False
        cell = cell * n + c
    return cell if ok else -1


@ti.func
def compute_acc(x: ti.template(), P: ti.template()):
    """P.acc[i] = (sum over j of the force on i) / m_i, gathered per particle."""
    if P.all_pairs == 0:
        build_grid(x, P)
    for i in range(x.shape[0]):
        f = vec3(0.0, 0.0, 0.0)
        if P.all_pairs == 1:
            for j in range(x.shape[0]):
                if j != i:
                    f -= pair_force(x, P, i, j)
        else:
            q = cell_coords(x, P, i)
            for oz, oy, ox in ti.ndrange((-1, 2), (-1, 2), (-1, 2)):
                cell = _neighbour_cell(P, q, ti.Vector([ox, oy, oz]))
                if cell >= 0:
                    for s in range(P.cell_start[cell], P.cell_end[cell]):
                        j = P.order[s]
                        if j != i:
                            f -= pair_force(x, P, i, j)
        P.acc[i] = f * P.inv_mass[i]


METHODS = {"velocity_verlet": 0, "symplectic_euler": 1, "explicit_euler": 2, "rk4": 3}
START = 4  # a(x0) into acc (velocity Verlet's carried acceleration), no step counted


@ti.func
def _before_stage(x: ti.template(), v: ti.template(), P: ti.template(), h, method, i, k):
    """What stage k does to particle i before the force evaluation at P.xs."""
    if method == 0:  # velocity Verlet: half kick with the carried a, drift
        v[i] = v[i] + (0.5 * h) * P.acc[i]
        x[i] = x[i] + h * v[i]
        P.xs[i] = x[i]
    elif method != 3 or k == 0:  # Euler steps, the start, RK4's first stage
        P.xs[i] = x[i]
        if method == 3:
            P.vs[i] = v[i]
            P.sx[i], P.sv[i] = vec3(0.0, 0.0, 0.0), vec3(0.0, 0.0, 0.0)


@ti.func
def _after_stage(x: ti.template(), v: ti.template(), P: ti.template(), h, method, i, k):
    """What stage k does to particle i with the acceleration a(P.xs) in P.acc."""
    if method == 0:
        v[i] = v[i] + (0.5 * h) * P.acc[i]
    elif method == 1:  # symplectic Euler: kick then drift
        v[i] = v[i] + h * P.acc[i]
        x[i] = x[i] + h * v[i]
    elif method == 2:  # explicit Euler: both from the old state
        x[i] = x[i] + h * v[i]
        v[i] = v[i] + h * P.acc[i]
    elif method == 3:  # classical RK4: b = (1, 2, 2, 1) / 6, c = (1/2, 1/2, 1)
        weight = 1.0 / 6.0 if (k == 0 or k == 3) else 1.0 / 3.0
        P.sx[i] += weight * P.vs[i]
        P.sv[i] += weight * P.acc[i]
        if k < 3:
            c = 1.0 if k == 2 else 0.5
            P.xs[i] = x[i] + (c * h) * P.vs[i]
            P.vs[i] = v[i] + (c * h) * P.acc[i]
        else:
            x[i] = x[i] + h * P.sx[i]
            v[i] = v[i] + h * P.sv[i]


@ti.kernel
def advance_lj(x: nd_vec3, v: nd_vec3, P: lj_t, h: f64, n: ti.i32, method: ti.i32):
    """n steps of h of stepper `method` (METHODS; START: a(x) only). One kernel for every
    stepper, one inlined force evaluation: compiled once per process."""
    ti.loop_config(serialize=True)  # the time loop: serial, and so is everything inside
    for _ in range(n):
        stages = 4 if method == 3 else 1
        for k in range(stages):
            for i in range(x.shape[0]):
                _before_stage(x, v, P, h, method, i, k)
            compute_acc(P.xs, P)
            for i in range(x.shape[0]):
                _after_stage(x, v, P, h, method, i, k)


def lj_kernels(integrator):
    """(start, advance) as kernel calls: start computes the carried acceleration (velocity
    Verlet only), advance(x, v, P, h, n) steps."""
    if integrator not in METHODS:
        raise ValueError(f"taichi lennard_jones integrator must be one of {list(METHODS)}, "
                         f"got {integrator!r}")
    code = METHODS[integrator]

    def start(x, v, P):
        advance_lj(x, v, P, 0.0, 1, START)

    def advance(x, v, P, h, n):
        advance_lj(x, v, P, h, n, code)
    return (start if code == 0 else None), advance
