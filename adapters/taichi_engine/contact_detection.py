"""Contact detection for colliding spheres as taichi functions: a uniform grid over the
bounding box (cell >= 2 r_max, counting sort of the ids, a half stencil of neighbour cells so
each pair is met once), and the contact list: pairs with |d| <= (r_a + r_b)(1 + slop) and
sphere-wall gaps <= slop r (the slop catches touching balls whose positions differ from
touching by round-off, as in the cradle). Each pair's normal is taken at the time of impact:
backed up along its relative path over the last drift to |d| = r_a + r_b (engine variant
`overlap_normal`: the centre line of the overlapped pose, as most engines).

A contact is (a, b, n) with n the unit normal from a to b; a = -1 - k stands for wall k (b is
then the sphere). `C` is the contact argpack (contact_kernels.contacts_t).
No `from __future__ import annotations` here: taichi reads `ti.template()` annotations as objects.
"""
from .kernel_types import f64, i32, ivec3, ti, vec3


# -- broad phase: uniform grid, counting sort ----------------------------------------------
@ti.func
def grid_dims(ext, cell_min, cap):
    """Cell size >= cell_min, enlarged until the grid over the bounding box fits `cap`."""
    c = cell_min
    nf = ti.floor(ext / c) + 1.0
    while nf[0] * nf[1] * nf[2] > cap:
        c *= ti.max(1.05, ti.pow(nf[0] * nf[1] * nf[2] / cap, 1.0 / 3.0))
        nf = ti.floor(ext / c) + 1.0
    return c, ti.cast(nf, i32)


@ti.func
def cell_coords(xi, lo, c, dims):
    return ti.min(ti.cast(ti.floor((xi - lo) / c), i32), dims - 1)


@ti.func
def build_grid(x: ti.template(), C: ti.template()):
    """Bounding box, cell size, then a serial counting sort: C.order lists the spheres
    cell by cell (index order within a cell), C.sorted_x their positions; cell k holds
    C.order[start[k]:count[k]].
    ok = 0 when a coordinate is not finite (no grid, no contacts)."""
    lo, hi = vec3(1e308, 1e308, 1e308), vec3(-1e308, -1e308, -1e308)
    ok = 1
    for i in range(x.shape[0]):
        lo, hi = ti.min(lo, x[i]), ti.max(hi, x[i])  # min/max may skip a nan: test each
        if not (ti.abs(x[i]) < 1e300).all():  # inf or nan
            ok = 0
    ext = hi - lo
    for k in ti.static(range(3)):
        if not ext[k] < 1e300:
            ok = 0
    c, dims = C.cell_min, ivec3(1, 1, 1)
    if ok:
        c, dims = grid_dims(ext, C.cell_min, ti.cast(C.cell_count.shape[0], f64))
        total = dims[0] * dims[1] * dims[2]
        for k in range(total):
            C.cell_count[k] = 0
        for i in range(x.shape[0]):
            q = cell_coords(x[i], lo, c, dims)
            cell = (q[2] * dims[1] + q[1]) * dims[0] + q[0]
            C.cell_of[i] = cell
            C.cell_count[cell] += 1
        running = 0
        for k in range(total):
            C.cell_start[k] = running
            running += C.cell_count[k]
            C.cell_count[k] = C.cell_start[k]  # now the fill pointer, then the cell's end
        for i in range(x.shape[0]):
            cell = C.cell_of[i]
            C.order[C.cell_count[cell]] = i
            C.sorted_x[C.cell_count[cell]] = x[i]
            C.cell_count[cell] += 1
    return lo, c, dims, ok


# -- narrow phase: contact normals ----------------------------------------------------------
@ti.func
def pair_normal(d, dd, R, rel, h, toi: ti.i32):
    """Unit normal from a to b (d = x_b - x_a, dd = |d|^2, R = r_a + r_b). With `toi`, the
    normal at the moment of touching on the straight relative path of the last drift,
    d - s rel with |d - s rel| = R (s > 0 in the past), when |s| <= h; else the centre
    line. The root is taken in its cancellation-free form."""
    n = vec3(1.0, 0.0, 0.0)
    if dd > 0.0:
        n = d / ti.sqrt(dd)
    if toi:
        ww = rel.dot(rel)
        if ww > 0.0:
            dw = d.dot(rel)
            disc = dw * dw - ww * (dd - R * R)
            if disc >= 0.0:
                sq = ti.sqrt(disc)
                s = 0.0
                if dw < 0.0:
                    s = (R * R - dd) / (sq - dw)
                else:
                    s = (dw + sq) / ww
                if ti.abs(s) <= h:
                    m = d - s * rel
                    n = m / m.norm()
    return n


@ti.func
def add_contact(C: ti.template(), nc, a, b, n):
    out = nc
    if nc < C.contact_a.shape[0]:
        C.contact_a[nc], C.contact_b[nc], C.contact_n[nc] = a, b, n
        out = nc + 1
    else:
        C.stats[0] += 1  # dropped: reported as a failure
    return out


@ti.func
def wall_contacts(x: ti.template(), C: ti.template(), i, nc):
    out = nc
    ri = C.radius[i]
    for k in range(C.n_walls):
        nw = C.wall_normal[k]
        if (x[i] - C.wall_point[k]).dot(nw) - ri <= C.slop * ri:
            out = add_contact(C, out, -1 - k, i, nw)
    return out


@ti.func
def find_contacts(x: ti.template(), v: ti.template(), C: ti.template(), h):
    """Contacts in a fixed order: sphere by sphere in cell order, its walls, then its
    partners in a half stencil of neighbouring cells, so each pair is met once. Cells of
    a row are contiguous in C.order, so the half stencil is five ranges: the rest of the
    own row up to cell x+1, row y+1 (cells x-1..x+1), and rows y-1..y+1 of layer z+1.
    A pair is in contact when |d| <= (r_a + r_b)(1 + slop), a wall when the gap <= slop r."""
    lo, c, dims, ok = build_grid(x, C)
    nc = 0
    if ok:
        for k in range(x.shape[0]):
            i = C.order[k]
            nc = wall_contacts(x, C, i, nc)
            q = cell_coords(C.sorted_x[k], lo, c, dims)
            x0, x1 = ti.max(q[0] - 1, 0), ti.min(q[0] + 1, dims[0] - 1)
            row = (q[2] * dims[1] + q[1]) * dims[0]
            nc = range_pairs(v, C, h, k, k + 1, C.cell_count[row + x1], nc)
            if q[1] + 1 < dims[1]:
                nc = row_pairs(v, C, h, k, row + dims[0], x0, x1, nc)
            if q[2] + 1 < dims[2]:
                for dy in range(-1, 2):
                    if 0 <= q[1] + dy < dims[1]:
                        nc = row_pairs(v, C, h, k, ((q[2] + 1) * dims[1] + q[1] + dy)
                                       * dims[0], x0, x1, nc)
    else:
        C.stats[1] += 1
    return nc


@ti.func
def row_pairs(v: ti.template(), C: ti.template(), h, k, row, x0, x1, nc):
    return range_pairs(v, C, h, k, C.cell_start[row + x0], C.cell_count[row + x1], nc)


@ti.func
def range_pairs(v: ti.template(), C: ti.template(), h, k, s0, s1, nc):
    """Sphere C.order[k] against C.order[s0:s1], on the cell-sorted positions; a contact
    is stored with a < b and its normal from a to b."""
    out = nc
    i, xi = C.order[k], C.sorted_x[k]
    for s in range(s0, s1):
        j = C.order[s]
        d = C.sorted_x[s] - xi
        R = C.radius[i] + C.radius[j]
        dd = d.dot(d)
        reach = R * (1.0 + C.slop)
        if dd <= reach * reach:
            a, b = i, j
            if j < i:
                a, b, d = j, i, -d
            out = add_contact(C, out, a, b, pair_normal(d, dd, R, v[b] - v[a], h,
                                                        C.toi_normal))
    return out
