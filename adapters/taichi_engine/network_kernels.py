"""Float64 taichi kernels of a spring network on its free nodes (refsim.models.spring_network's
model: stretch springs with damping along the edge, air drag, gravity; an edge to a pinned node
is a spring to a fixed anchor), and the four steppers of the spring-network group:

- symplectic Euler, velocity Verlet (closing half kick corrected once when forces depend on v)
  and RK4, with refsim's arithmetic, the time loop inside one kernel
  (`ti.loop_config(serialize=True)`: the sweeps over springs and nodes are serial too); the
  RK4 kernel is made by `make_rk4` over the acceleration function, shared with fem_kernels;
- Baraff-Witkin's (M - h D - h^2 K) dv = h (f + h K v): one kernel computes f, the right-hand
  side and the per-spring 3x3 blocks of A = M - h D - h^2 K, and either enters the blocks as
  triplets into a ti.linalg.SparseMatrixBuilder (the direct solve) or keeps them for
  `conjugate_gradient`, a matrix-free CG over the blocks, all its iterations in one kernel.

Blocks of spring s, d = x_i - x_j (or x_i - anchor), u = d / |d|, r = L0 / |d| (0 at |d| = 0):
K_s = -k ((1 - r) I + r u u^T), D_s = -c u u^T (the x-derivative of the damping direction left
out, as refsim's JacobianAssembler); A_s = -h D_s - h^2 K_s enters (i, i) and (j, j) with +,
(i, j) and (j, i) with -; the masses and h c_air (air drag, D = -c_air I) enter the diagonal.
Forces are accumulated per node in two passes (every spring's `body` end, then every `other`
end), the order of refsim's indexed adds.
No `from __future__ import annotations` here: taichi reads annotations as objects.
"""
from .kernel_types import f64, i32, nd_f64, nd_i32, nd_vec3, ti, vec3

mat3 = ti.types.matrix(3, 3, f64)
nd_mat3 = ti.types.ndarray(dtype=mat3, ndim=1)

# one network on its free nodes: masses, gravity, air drag, springs (other = -1: an anchor);
# a network with bending terms extends these fields (bending_kernels)
NET_FIELDS = {"mass": nd_f64, "inv_m": nd_f64, "gravity": vec3, "drag": f64, "body": nd_i32,
              "other": nd_i32, "anchor": nd_vec3, "k": nd_f64, "rest": nd_f64, "c": nd_f64,
              "damped": i32, "velocity_dependent": i32}
net_t = ti.types.argpack(**NET_FIELDS)


@ti.func
def spring_axis(P: ti.template(), x: ti.template(), v: ti.template(), s, off):
    """(dv, |d|, u) of spring s, nodes at x[off + i] (u = 0 where |d| = 0)."""
    i, j = P.body[s] + off, P.other[s]
    d, dv = x[i] - P.anchor[s], v[i]
    if j >= 0:
        d, dv = x[i] - x[j + off], v[i] - v[j + off]
    length = ti.sqrt(d.dot(d))
    u = vec3(0.0, 0.0, 0.0)
    if length > 0.0:
        u = d / length
    return dv, length, u


@ti.func
def spring_force(P: ti.template(), x: ti.template(), v: ti.template(), s, off):
    """Force of spring s on its body end: -k (|d| - L0) u - c (dv . u) u."""
    dv, length, u = spring_axis(P, x, v, s, off)
    f = -(P.k[s] * (length - P.rest[s])) * u
    if P.damped:
        f = f - (P.c[s] * dv.dot(u)) * u
    return f


@ti.func
def spring_sum(P: ti.template(), x: ti.template(), v: ti.template(), a: ti.template(), off):
    """a = f_springs on every free node (forces); node i at x[off + i], v[off + i],
    a[off + i] (RK4 keeps its four stages in one array)."""
    for i in range(P.mass.shape[0]):
        a[off + i] = vec3(0.0, 0.0, 0.0)
    for s in range(P.body.shape[0]):
        a[P.body[s] + off] += spring_force(P, x, v, s, off)
    for s in range(P.body.shape[0]):
        j = P.other[s]
        if j >= 0:
            a[j + off] += -spring_force(P, x, v, s, off)


@ti.func
def accel(P: ti.template(), x: ti.template(), v: ti.template(), a: ti.template(), off):
    """a = (f_springs - drag v) / m + g on every free node (one closing sweep; the bending
    family's accel splits it: bending_kernels)."""
    spring_sum(P, x, v, a, off)
    for i in range(P.mass.shape[0]):
        a[off + i] = (a[off + i] - P.drag * v[off + i]) * P.inv_m[i] + P.gravity


def make_rk4(pack_t, nd_vec, accel_fn, after_step=None):
    """The RK4 kernel over argpacks of type pack_t and state ndarrays of type nd_vec, with the
    acceleration ti.func accel_fn(P, x, v, a, off) (shared by the spring networks and the FEM
    meshes, whose accel ignores v) and an optional after_step(P, x) ti.func run after each
    step (the FEM group's plastic commit)."""
    closing = after_step is not None  # a Python bool: taichi's AST has no `is not`

    @ti.kernel
    def rk4(P: pack_t, x: nd_vec, v: nd_vec, xs: nd_vec, vs: nd_vec, acc: nd_vec, h: f64,
            n: i32):
        """Classical RK4 on (x, v): stage s (X_1 = x, V_1 = v) X_s = x + (a_s h) V_s-1,
        V_s = v + (a_s h) A_s-1, A_s = a(X_s, V_s), a = (1/2, 1/2, 1); the four stages at offsets
        s n of xs, vs, acc (one inlined force sweep, not four); then x += (b_s h) V_s,
        v += (b_s h) A_s summed in stage order, b = (1/6, 1/3, 1/3, 1/6)."""
        m = x.shape[0]
        ti.loop_config(serialize=True)
        for _ in range(n):
            for st in range(4):
                off, back = st * m, (st - 1) * m
                if st == 0:
                    for i in range(m):
                        xs[i], vs[i] = x[i], v[i]
                else:
                    ha = (1.0 if st == 3 else 0.5) * h
                    for i in range(m):
                        xs[off + i] = x[i] + ha * vs[back + i]
                        vs[off + i] = v[i] + ha * acc[back + i]
                accel_fn(P, xs, vs, acc, off)
            h6, h3 = (1.0 / 6.0) * h, (1.0 / 3.0) * h
            for i in range(m):
                x[i] = x[i] + h6 * vs[i] + h3 * vs[m + i] + h3 * vs[2 * m + i] + \
                    h6 * vs[3 * m + i]
                v[i] = v[i] + h6 * acc[i] + h3 * acc[m + i] + h3 * acc[2 * m + i] + \
                    h6 * acc[3 * m + i]
            if ti.static(closing):
                after_step(P, x)

    return rk4


def make_steppers(pack_t, accel_fn):
    """(start, symplectic_euler, velocity_verlet, rk4) kernels over argpacks of type pack_t
    with the acceleration ti.func accel_fn(P, x, v, a, off): one kernel family per force
    model (a network without bending compiles none of the bending code)."""

    @ti.kernel
    def start(P: pack_t, x: nd_vec3, v: nd_vec3, a: nd_vec3):
        """a = a(x, v): velocity Verlet's carried acceleration."""
        ti.loop_config(serialize=True)
        for _ in range(1):
            accel_fn(P, x, v, a, 0)

    @ti.kernel
    def symplectic_euler(P: pack_t, x: nd_vec3, v: nd_vec3, a: nd_vec3, h: f64, n: i32):
        """Kick-drift: v += h a(x, v); x += h v."""
        ti.loop_config(serialize=True)
        for _ in range(n):
            accel_fn(P, x, v, a, 0)
            for i in range(x.shape[0]):
                v[i] = v[i] + h * a[i]
                x[i] = x[i] + h * v[i]

    @ti.kernel
    def velocity_verlet(P: pack_t, x: nd_vec3, v: nd_vec3, a: nd_vec3, vh: nd_vec3, w: nd_vec3,
                        h: f64, n: i32):
        """Half kick, drift, a(x1, vh), half kick; once more with a(x1, v1) when forces depend on
        v. The velocity a is taken at is copied into w first (one inlined force sweep, not two:
        half the compile time; a copy changes no bit)."""
        ti.loop_config(serialize=True)
        for _ in range(n):
            for i in range(x.shape[0]):
                vh[i] = v[i] + (0.5 * h) * a[i]
                x[i] = x[i] + h * vh[i]
                w[i] = vh[i]
            for sweep in range(1 + P.velocity_dependent):
                if sweep == 1:
                    for i in range(x.shape[0]):
                        w[i] = v[i]
                accel_fn(P, x, w, a, 0)
                for i in range(x.shape[0]):
                    v[i] = vh[i] + (0.5 * h) * a[i]

    return start, symplectic_euler, velocity_verlet, make_rk4(pack_t, nd_vec3, accel_fn)


start, symplectic_euler, velocity_verlet, rk4 = make_steppers(net_t, accel)


# ----- Baraff-Witkin ----------------------------------------------------------------------------
@ti.func
def system(P: ti.template(), x: ti.template(), v: ti.template(), a: ti.template(),
           kv: ti.template(), blocks: ti.template(), rhs: ti.template(), h):
    """Blocks A_s = -h D_s - h^2 K_s and rhs = h (m a + h K v), flat (3 n_free,)."""
    accel(P, x, v, a, 0)
    for i in range(x.shape[0]):
        kv[i] = vec3(0.0, 0.0, 0.0)
    for s in range(P.body.shape[0]):
        _, length, u = spring_axis(P, x, v, s, 0)
        uu = u.outer_product(u)
        ratio = 0.0
        if length > 0.0:
            ratio = P.rest[s] / length
        k_block = -P.k[s] * ((1.0 - ratio) * ti.Matrix.identity(f64, 3) + ratio * uu)
        blocks[s] = -h * (-P.c[s] * uu) - (h * h) * k_block
        i, j = P.body[s], P.other[s]
        dv = v[i]
        if j >= 0:
            dv = v[i] - v[j]
        kv[i] += k_block @ dv
        if j >= 0:
            kv[j] -= k_block @ dv
    for i in range(x.shape[0]):
        r = h * (P.mass[i] * a[i] + h * kv[i])
        for c in ti.static(range(3)):
            rhs[3 * i + c] = r[c]


@ti.kernel
def bw_triplets(P: net_t, x: nd_vec3, v: nd_vec3, a: nd_vec3, kv: nd_vec3, blocks: nd_mat3,
                rhs: nd_f64, A: ti.types.sparse_matrix_builder(), h: f64):
    """The system of one step, A's triplets entered into the builder."""
    ti.loop_config(serialize=True)
    for _ in range(1):
        system(P, x, v, a, kv, blocks, rhs, h)
        for i in range(x.shape[0]):
            for c in ti.static(range(3)):
                A[3 * i + c, 3 * i + c] += P.mass[i] + h * P.drag
        for s in range(P.body.shape[0]):
            i, j = P.body[s], P.other[s]
            for r, c in ti.static(ti.ndrange(3, 3)):
                A[3 * i + r, 3 * i + c] += blocks[s][r, c]
                if j >= 0:
                    A[3 * j + r, 3 * j + c] += blocks[s][r, c]
                    A[3 * i + r, 3 * j + c] += -blocks[s][r, c]
                    A[3 * j + r, 3 * i + c] += -blocks[s][r, c]


@ti.kernel
def bw_blocks(P: net_t, x: nd_vec3, v: nd_vec3, a: nd_vec3, kv: nd_vec3, blocks: nd_mat3,
              rhs: nd_f64, h: f64):
    """The system of one step, A kept as its blocks (for the matrix-free CG)."""
    ti.loop_config(serialize=True)
    for _ in range(1):
        system(P, x, v, a, kv, blocks, rhs, h)


@ti.func
def apply(P: ti.template(), blocks: ti.template(), p: ti.template(), out: ti.template(), h):
    """out = A p, A = M + h c_air I + the spring blocks (flat vectors of 3 n_free)."""
    for q in range(out.shape[0]):
        out[q] = (P.mass[q // 3] + h * P.drag) * p[q]
    for s in range(P.body.shape[0]):
        i, j = P.body[s], P.other[s]
        pi = vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2])
        dp = pi
        if j >= 0:
            dp = pi - vec3(p[3 * j], p[3 * j + 1], p[3 * j + 2])
        y = blocks[s] @ dp
        for c in ti.static(range(3)):
            out[3 * i + c] += y[c]
            if j >= 0:
                out[3 * j + c] -= y[c]


@ti.func
def dot(p: ti.template(), q: ti.template()):
    total = 0.0
    for k in range(p.shape[0]):
        total += p[k] * q[k]
    return total


@ti.kernel
def conjugate_gradient(P: net_t, blocks: nd_mat3, b: nd_f64, x: nd_f64, r: nd_f64, p: nd_f64,
                       ap: nd_f64, h: f64, rtol: f64, maxiter: i32) -> i32:
    """A x = b by CG from x = 0 until |r| < rtol |b| (scipy.sparse.linalg.cg's test with
    atol = 0; b = 0 gives x = 0 at once, as there); returns the iterations taken, -1 when
    maxiter was reached first."""
    iterations = 0
    ti.loop_config(serialize=True)
    for _ in range(1):
        for k in range(b.shape[0]):
            x[k] = 0.0
            r[k] = b[k]
            p[k] = b[k]
        tol2 = rtol * rtol * dot(b, b)
        rr = dot(r, r)
        it = 0
        while it < maxiter and rr >= tol2 and rr > 0.0:
            apply(P, blocks, p, ap, h)
            alpha = rr / dot(p, ap)
            for k in range(b.shape[0]):
                x[k] += alpha * p[k]
                r[k] -= alpha * ap[k]
            rr_new = dot(r, r)
            beta = rr_new / rr
            for k in range(b.shape[0]):
                p[k] = r[k] + beta * p[k]
            rr = rr_new
            it += 1
        iterations = -1
        if rr < tol2 or rr == 0.0:
            iterations = it
    return iterations
