"""Float64 taichi kernels of the viscous term on the MAC faces (refsim.models.grid_fluid.
viscosity): the explicit step a + dt nu lap a and the triplets of I - dt nu M for the implicit
one, per face component, 5-point rows: along the component's own (staggered) axis the wall
faces are Dirichlet 0; across it the no-slip ghost 2 w - a (w the lid beyond the last entry of
axis 1 for u, else 0) makes the end rows (a_1 - 3 a_0 + 2 w) / h^2; periodic axes wrap their
distinct entries. The explicit sweep sums each axis' second difference and then the two
(refsim's CSR product sums the row's entries in column order): equal up to round-off.
No `from __future__ import annotations` here: taichi reads annotations as objects.
"""
from .fluid_kernels import geo_t, grid_t
from .kernel_types import f64, i32, ti


@ti.kernel
def viscous_step(a: grid_t, out: grid_t, axis: i32, g: geo_t, c: f64, top: f64):
    """out = a + c lap a on the moving faces of a component staggered along `axis` (explicit
    viscosity, c = dt nu; viscosity.ViscousOperator's 5-point rows), other entries copied:
    along the staggered axis the wall faces are Dirichlet 0; across it the no-slip ghost
    2 w - a (w = `top` beyond the last entry of axis 1, else 0); periodic axes wrap their
    distinct entries (a staggered one drops its duplicate last face)."""
    inv_h2 = 1.0 / (g.h * g.h)
    for i, j in a:
        moving = True
        if axis == 0:
            moving = (i < g.nx) if g.px else (0 < i < g.nx)
        else:
            moving = (j < g.ny) if g.py else (0 < j < g.ny)
        out[i, j] = a[i, j]
        if moving:
            here = a[i, j]
            lap = 0.0
            for ax in ti.static(range(2)):
                k = i if ti.static(ax == 0) else j
                count = a.shape[ax]
                periodic = g.px if ti.static(ax == 0) else g.py
                staggered = axis == ax
                lower, upper = 0.0, 0.0
                if periodic:
                    m = count - 1 if staggered else count  # distinct entries
                    kl, ku = (k - 1 + m) % m, (k + 1) % m
                    lower = a[kl, j] if ti.static(ax == 0) else a[i, kl]
                    upper = a[ku, j] if ti.static(ax == 0) else a[i, ku]
                elif staggered:  # the wall faces 0 and count - 1 are Dirichlet 0
                    if k - 1 > 0:
                        lower = a[k - 1, j] if ti.static(ax == 0) else a[i, k - 1]
                    if k + 1 < count - 1:
                        upper = a[k + 1, j] if ti.static(ax == 0) else a[i, k + 1]
                else:  # centred: no-slip ghosts beyond the first and last entries
                    lower = -here
                    if k > 0:
                        lower = a[k - 1, j] if ti.static(ax == 0) else a[i, k - 1]
                    w_hi = top if ti.static(ax == 1) else 0.0
                    upper = 2.0 * w_hi - here
                    if k < count - 1:
                        upper = a[k + 1, j] if ti.static(ax == 0) else a[i, k + 1]
                lap += (lower - 2.0 * here + upper) * inv_h2
            out[i, j] = here + c * lap


@ti.kernel
def assemble_viscous(builder: ti.types.sparse_matrix_builder(), m0: i32, m1: i32, axis: i32,
                     px: i32, py: i32, c: f64, h2: f64):
    """Triplets of I - c M on the (m0, m1) moving faces (C order) of the component staggered
    along `axis`; M's entries as refsim builds them: the Kronecker sum's (d0 + d1) / h^2 on
    the diagonal (d = -2, or -3 at a centred wall's end rows), 1 / h^2 off it; c = dt nu."""
    for a, b in ti.ndrange(m0, m1):
        r = a * m1 + b
        d = 0.0
        for ax in ti.static(range(2)):
            k = a if ti.static(ax == 0) else b
            m = m0 if ti.static(ax == 0) else m1
            periodic = px if ti.static(ax == 0) else py
            d += -2.0
            if not periodic and axis != ax:
                if k == 0:
                    d += -1.0
                if k == m - 1:
                    d += -1.0
            for s in ti.static((-1, 1)):
                kk = k + s
                ok = 0 <= kk < m
                if periodic:
                    kk = (kk + m) % m
                    ok = True
                if ok:
                    col = kk * m1 + b if ti.static(ax == 0) else a * m1 + kk
                    builder[r, col] += -(c * (1.0 / h2))
        builder[r, r] += 1.0 - c * (d / h2)
