"""Float64 taichi kernels of refsim's MAC-grid fluid step (refsim.models.grid_fluid states the
conventions): ghost layers, semi-Lagrangian advection of the face velocities, body force and
boundaries, divergence, the pressure operator A = G^T G applied matrix-free and assembled, the
gradient subtraction (the viscous kernels: fluid_viscosity_kernels; the multigrid's:
fluid_multigrid). The advection does refsim's numpy operations in the same order (ghost
formulas, index coordinates, the bilinear and Catmull-Rom interpolants, the backtraces'
tableaux): bit for bit (tested). A p's stencil is summed in a fixed order, not scipy's CSR
order, and the gradient as (p_high - p_low) / h: equal to round-off.

Arrays: 2D numpy float64 arrays (u (nx + 1, ny), v (nx, ny + 1), cells (nx, ny)) handed as
external arrays (arch=cpu: zero-copy), int32 masks. Geometry (`geo_t`): nx, ny, h, per axis
periodic (1) or wall (0), the lid.

Ghost layers (`pad`): refsim.models.grid_fluid.mac.padded's rules, axis 0 then axis 1 (the
corners from the axis-0 ghosts, as numpy's concatenations give them): periodic wrap of the n
distinct entries; a staggered wall axis odd about the end face, 2 a[0] - a[k]; a centred wall
axis no-slip about the wall's value, 2 w - a[k] (u at the top: the lid), or "even" (mirror).
No `from __future__ import annotations` here: taichi reads annotations as objects.
"""
from .kernel_types import f64, i32, ti

GHOST = 2
INTERP = {"linear": 0, "cubic": 1, "cubic_clamped": 2}
BACKTRACE = {"euler": 1, "rk2": 2, "rk3": 3}

geo_t = ti.types.argpack(nx=i32, ny=i32, h=f64, px=i32, py=i32, lid=f64)
grid_t = ti.types.ndarray(dtype=f64, ndim=2)
mask_t = ti.types.ndarray(dtype=i32, ndim=2)


def geometry(nx, ny, h, periodic, lid):
    return geo_t(nx=int(nx), ny=int(ny), h=float(h), px=int(periodic[0]), py=int(periodic[1]),
                 lid=float(lid))


def padded_shape(shape, staggered, periodic):
    """The padded array's shape: a periodic staggered axis drops its duplicate last face."""
    return tuple(n + 2 * GHOST - (1 if s and p else 0)
                 for n, s, p in zip(shape, staggered, periodic))


# -- ghost layers ------------------------------------------------------------------------------
@ti.func
def source(k: i32, n: i32, periodic: i32, staggered: i32, even: i32):
    """Where padded entry k - GHOST along an axis comes from: (index, kind, end) with kind 0 a
    copy of a[index], 1 odd about the end face (2 a[end] - a[index]), 2 no-slip about the
    wall value (2 w - a[index]); n the distinct entries (faces - 1 on a staggered axis)."""
    idx, kind, end = k, 0, 0
    if periodic:
        if idx < 0:
            idx += n
        if idx >= n:
            idx -= n
    elif staggered:
        if k < 0:
            idx, kind, end = -k, 1, 0
        elif k > n:
            idx, kind, end = 2 * n - k, 1, n
    elif k < 0:
        idx, kind = -k - 1, 0 if even else 2
    elif k >= n:
        idx, kind = 2 * n - 1 - k, 0 if even else 2
    return idx, kind, end


@ti.kernel
def pad(a: grid_t, out: grid_t, sx: i32, sy: i32, px: i32, py: i32, even: i32, low_x: f64,
        high_x: f64, low_y: f64, high_y: f64):
    """out = a with GHOST entries per side and axis (mac.padded: axis 0, then axis 1)."""
    n0 = a.shape[0] - sx
    n1 = a.shape[1] - sy
    for P, j in ti.ndrange(out.shape[0], a.shape[1]):
        idx, kind, end = source(P - GHOST, n0, px, sx, even)
        val = a[idx, j]
        if kind == 1:
            val = 2.0 * a[end, j] - a[idx, j]
        elif kind == 2:
            w = low_x if P < GHOST else high_x
            val = 2.0 * w - a[idx, j]
        out[P, j + GHOST] = val
    for P, Q in ti.ndrange(out.shape[0], out.shape[1]):
        if Q < GHOST or Q >= GHOST + n1 + (1 - py) * sy:
            idx, kind, end = source(Q - GHOST, n1, py, sy, even)
            val = out[P, idx + GHOST]
            if kind == 1:
                val = 2.0 * out[P, end + GHOST] - out[P, idx + GHOST]
            elif kind == 2:
                w = low_y if Q < GHOST else high_y
                val = 2.0 * w - out[P, idx + GHOST]
            out[P, Q] = val


# -- sampling ----------------------------------------------------------------------------------
@ti.func
def coordinate(x, h, n: i32, periodic: i32, staggered: i32):
    """mac.index_coordinates along one axis: x / h - offset, wrapped or clamped, + GHOST."""
    q = x / h - (0.0 if staggered else 0.5)
    if periodic:
        q = q - n * ti.floor(q / n)
        if q < 0.0:  # q / n rounded up to an integer: np.mod adds n to the remainder
            q += n
    else:
        low = 0.0 if staggered else -0.5
        q = ti.min(ti.max(q, low), low + n)
    return q + GHOST


@ti.func
def bilinear(pad: ti.template(), qx, qy):
    i = ti.min(ti.max(ti.cast(ti.floor(qx), i32), 0), pad.shape[0] - 2)
    j = ti.min(ti.max(ti.cast(ti.floor(qy), i32), 0), pad.shape[1] - 2)
    tx, ty = qx - i, qy - j
    return ((1 - tx) * ((1 - ty) * pad[i, j] + ty * pad[i, j + 1])
            + tx * ((1 - ty) * pad[i + 1, j] + ty * pad[i + 1, j + 1]))


@ti.func
def catmull_rom(t):
    t2, t3 = t * t, t * t * t
    return ti.Vector([0.5 * (-t3 + 2 * t2 - t), 0.5 * (3 * t3 - 5 * t2 + 2),
                      0.5 * (-3 * t3 + 4 * t2 + t), 0.5 * (t3 - t2)])


@ti.func
def cubic(pad: ti.template(), qx, qy, clamped: i32):
    i = ti.min(ti.max(ti.cast(ti.floor(qx), i32), 1), pad.shape[0] - 3)
    j = ti.min(ti.max(ti.cast(ti.floor(qy), i32), 1), pad.shape[1] - 3)
    wx, wy = catmull_rom(qx - i), catmull_rom(qy - j)
    out = 0.0
    for a in ti.static(range(4)):
        row = 0.0
        for b in ti.static(range(4)):
            row = row + wy[b] * pad[i + a - 1, j + b - 1]
        out = out + wx[a] * row
    if clamped:
        lo = ti.min(ti.min(pad[i, j], pad[i + 1, j]), ti.min(pad[i, j + 1], pad[i + 1, j + 1]))
        hi = ti.max(ti.max(pad[i, j], pad[i + 1, j]), ti.max(pad[i, j + 1], pad[i + 1, j + 1]))
        out = ti.min(ti.max(out, lo), hi)
    return out


@ti.func
def velocity(pu: ti.template(), pv: ti.template(), g: ti.template(), x, y):
    """The bilinear velocity (mac.velocity_sampler) at (x, y)."""
    ux = coordinate(x, g.h, g.nx, g.px, 1)
    uy = coordinate(y, g.h, g.ny, g.py, 0)
    vx = coordinate(x, g.h, g.nx, g.px, 0)
    vy = coordinate(y, g.h, g.ny, g.py, 1)
    return ti.Vector([bilinear(pu, ux, uy), bilinear(pv, vx, vy)])


@ti.func
def departure(pu: ti.template(), pv: ti.template(), g: ti.template(), p, dt, stepper: i32):
    """advection.backtrace: euler, rk2 (explicit midpoint) or rk3 (Ralston)."""
    k1 = velocity(pu, pv, g, p[0], p[1])
    out = p - dt * k1
    if stepper == 2:
        m = p - (0.5 * dt) * k1
        out = p - dt * velocity(pu, pv, g, m[0], m[1])
    elif stepper == 3:
        m = p - (0.5 * dt) * k1
        k2 = velocity(pu, pv, g, m[0], m[1])
        m3 = p - (0.75 * dt) * k2
        k3 = velocity(pu, pv, g, m3[0], m3[1])
        out = p - dt * ((2.0 / 9.0) * k1 + (1.0 / 3.0) * k2 + (4.0 / 9.0) * k3)
    return out


@ti.kernel
def advect(a_pad: grid_t, pu: grid_t, pv: grid_t, out: grid_t, g: geo_t, dt: f64, sx: i32,
           sy: i32, interp: i32, stepper: i32):
    """out[i, j] = the face array (padded a_pad, staggered along sx / sy) at the departure
    point of its face (advection.advect_faces, before the boundaries)."""
    for i, j in out:
        p = ti.Vector([(i + (0.0 if sx else 0.5)) * g.h, (j + (0.0 if sy else 0.5)) * g.h])
        d = departure(pu, pv, g, p, dt, stepper)
        qx = coordinate(d[0], g.h, g.nx, g.px, sx)
        qy = coordinate(d[1], g.h, g.ny, g.py, sy)
        if interp == 0:
            out[i, j] = bilinear(a_pad, qx, qy)
        else:
            out[i, j] = cubic(a_pad, qx, qy, interp - 1)


@ti.kernel
def force_and_walls(u: grid_t, v: grid_t, su: mask_t, sv: mask_t, g: geo_t, fx: f64,
                    fy: f64, force: i32, walls: i32, solids: i32):
    """u += fx, v += fy (where `force`); then, where `walls`, mac.enforce_boundaries (wall
    faces 0, a periodic axis' last faces = its first); where `solids`, solid faces 0."""
    if force:
        for i, j in u:
            u[i, j] = u[i, j] + fx
        for i, j in v:
            v[i, j] = v[i, j] + fy
    if walls:
        for j in range(g.ny):
            if g.px:
                u[g.nx, j] = u[0, j]
            else:
                u[0, j] = 0.0
                u[g.nx, j] = 0.0
        for i in range(g.nx):
            if g.py:
                v[i, g.ny] = v[i, 0]
            else:
                v[i, 0] = 0.0
                v[i, g.ny] = 0.0
    if solids:
        for i, j in u:
            if su[i, j]:
                u[i, j] = 0.0
        for i, j in v:
            if sv[i, j]:
                v[i, j] = 0.0


# -- projection --------------------------------------------------------------------------------
@ti.kernel
def rhs(u: grid_t, v: grid_t, b: grid_t, g: geo_t, dt: f64):
    """b = -D u / dt per cell, D u = ((u[i+1] - u[i]) + (v[j+1] - v[j])) / h."""
    for i, j in b:
        b[i, j] = -(((u[i + 1, j] - u[i, j]) + (v[i, j + 1] - v[i, j])) / g.h) / dt


@ti.func
def neighbour(i: i32, j: i32, axis: ti.template(), side: i32, g: ti.template()):
    """The cell across the face on `side` (-1 low, +1 high) of cell (i, j) along `axis`
    (wrapped on a periodic axis; its index may fall outside on a wall axis)."""
    n = g.nx if ti.static(axis == 0) else g.ny
    periodic = g.px if ti.static(axis == 0) else g.py
    k = (i if ti.static(axis == 0) else j) + side
    if periodic:
        if k < 0:
            k += n
        elif k >= n:
            k -= n
    return k


@ti.kernel
def apply_pressure(p: grid_t, out: grid_t, au: mask_t, av: mask_t, fluid: mask_t, g: geo_t,
                   w: f64):
    """out = A p on the fluid cells (0 elsewhere): sum over the cell's active faces of
    w (p_c - p_other), p_other = 0 unless FLUID (air: p = 0), w = 1/h^2."""
    for i in range(out.shape[0]):  # rows in parallel, each row serial (multigrid's note)
        for j in range(out.shape[1]):
            acc = 0.0
            if fluid[i, j]:
                for s in ti.static((-1, 1)):
                    fi = i if s < 0 else (i + 1 if (i + 1 < g.nx or not g.px) else 0)
                    fj = j if s < 0 else (j + 1 if (j + 1 < g.ny or not g.py) else 0)
                    if au[fi, j]:
                        k = neighbour(i, j, 0, s, g)
                        other = p[k, j] if fluid[k, j] else 0.0
                        acc += w * (p[i, j] - other)
                    if av[i, fj]:
                        k = neighbour(i, j, 1, s, g)
                        other = p[i, k] if fluid[i, k] else 0.0
                        acc += w * (p[i, j] - other)
            out[i, j] = acc


@ti.kernel
def assemble_pressure(builder: ti.types.sparse_matrix_builder(), column: mask_t, au: mask_t,
                      av: mask_t, w: f64):
    """A's triplets on the unknowns `column` (-1: not an unknown: non-fluid or pinned):
    per active face between cells c and d, w on each unknown end's diagonal and -w between
    two unknowns. Active faces: au (nx + 1, ny) and av (nx, ny + 1); a periodic axis' face 0
    links the last cell to the first."""
    nx, ny = column.shape[0], column.shape[1]
    for i, j in au:
        if au[i, j]:
            lo = column[(i - 1 + nx) % nx, j]  # face 0 active only on a periodic axis
            hi = column[i, j]  # the last face is never active (wall or duplicate)
            _face_triplets(builder, lo, hi, w)
    for i, j in av:
        if av[i, j]:
            lo = column[i, (j - 1 + ny) % ny]
            hi = column[i, j]
            _face_triplets(builder, lo, hi, w)


@ti.func
def _face_triplets(builder: ti.template(), lo: i32, hi: i32, w: f64):
    if lo >= 0:
        builder[lo, lo] += w
    if hi >= 0:
        builder[hi, hi] += w
    if lo >= 0 and hi >= 0:
        builder[lo, hi] += -w
        builder[hi, lo] += -w


@ti.kernel
def subtract_gradient(u: grid_t, v: grid_t, p: grid_t, au: mask_t, av: mask_t, g: geo_t,
                      dt: f64):
    """u -= dt G p on the active faces (G p = (p_high - p_low) / h, p = 0 outside the fluid,
    which `p` holds), then a periodic axis' last faces = its first."""
    for i, j in u:
        if au[i, j]:
            lo = p[(i - 1 + g.nx) % g.nx, j]
            hi = p[i, j]
            u[i, j] = u[i, j] - dt * ((hi - lo) / g.h)
    for i, j in v:
        if av[i, j]:
            lo = p[i, (j - 1 + g.ny) % g.ny]
            hi = p[i, j]
            v[i, j] = v[i, j] - dt * ((hi - lo) / g.h)
    for j in range(g.ny):
        if g.px:
            u[g.nx, j] = u[0, j]
    for i in range(g.nx):
        if g.py:
            v[i, g.ny] = v[i, 0]


@ti.kernel
def max_divergence(u: grid_t, v: grid_t, fluid: mask_t, g: geo_t) -> f64:
    """max |D u| over the fluid cells."""
    out = 0.0
    for i, j in fluid:
        if fluid[i, j]:
            d = ((u[i + 1, j] - u[i, j]) + (v[i, j + 1] - v[i, j])) / g.h
            ti.atomic_max(out, ti.abs(d))
    return out
