"""Float64 taichi kernels of a P1 finite-element mesh (refsim.models.fem.elements and
FemSystem's model): deformation gradients, the laws' stresses (`fem_stress`) or the von
Mises return from the committed plastic state (`fem_plastic`, committed after each step of
every stepper), nodal forces, lumped masses, loads and gravity, the four explicit steppers of
the fem group, and the tangent stiffness's triplets (scale K + diag M, and K w) for the static
Newton solve and the implicit steppers (`fem_implicit`).

All in the body's own coordinates (d = 2: the triangles' plane; d = 3: the world), every
node in the arrays, pinned ones included (inverse mass 0: their acceleration is 0, so with
v = 0 every stepper leaves them exactly where they are). Per element e with nodes
c_0..c_d: Ds = [x_c1 - x_c0, ...] (columns), F = Ds Dm^-1, H = (-V) (P(F) Dm^-T); node c_a
(a >= 1) gets column a - 1 of H, node c_0 minus their sum (refsim's element_forces), summed
into the nodes with atomic adds in element order (every kernel's outer loop is serialized,
so each node's sum runs over its elements ascending, the order of refsim's incidence matrix
rows: the masses come out bit-identical; the forces within round-off: refsim's explicit path
(refsim.models.fem.tensors) forms F and the element forces through sparse maps entry by entry,
and its other paths by numpy's batched matmul and LAPACK's det, which round differently).
Masses m = sum rho V / (d + 1) the same way; a = (f + ext) inv_m with ext = loads + m g and
inv_m = 1 / m on free nodes (refsim's accel: forces times 1 / m).

`kernels(d, law, plane_strain, plastic)` makes one family per element dimension, law and
plasticity, once per process (taichi compiles each kernel on its first call).
No `from __future__ import annotations` here: taichi reads annotations as objects.
"""
from types import SimpleNamespace

from .fem_plastic import plastic_functions
from .fem_stress import law_functions
from .kernel_types import f64, i32, nd_f64, nd_i32, ti
from .network_kernels import make_rk4
from .runtime import runtime


def cell_type(d):
    return ti.types.vector(d + 1, i32)


def pack_type(d):
    """The argpack of one mesh in dimension d (and its ndarray types)."""
    vec, mat = ti.types.vector(d, f64), ti.types.matrix(d, d, f64)
    nd_vec = ti.types.ndarray(dtype=vec, ndim=1)
    fields = {"cells": ti.types.ndarray(dtype=cell_type(d), ndim=1),
              "dm_inv": ti.types.ndarray(dtype=mat, ndim=1), "volume": nd_f64,
              "density": f64, "mass": nd_f64, "inv_m": nd_f64, "loads": nd_vec,
              "gravity": vec, "ext": nd_vec, "free_index": nd_i32,
              "mu": f64, "lam": f64, "alpha": f64,
              "eps_p": ti.types.ndarray(dtype=ti.types.matrix(3, 3, f64), ndim=1),
              "equiv": nd_f64, "sigma_y": f64, "hardening": f64}
    return ti.types.argpack(**fields), nd_vec, vec, mat


def make_kernels(d, law, plane_strain, plastic):
    pack_t, nd_vec, vec, mat = pack_type(d)
    stress, differential = law_functions(law, plane_strain)
    plastic_stress, plastic_commit = plastic_functions(law, plane_strain) if plastic else \
        (None, None)

    @ti.func
    def gradient(P: ti.template(), x: ti.template(), e, off):
        """F = Ds Dm^-1 of element e (nodes at x[off + c])."""
        c = P.cells[e]
        ds = mat(0.0)
        for a in ti.static(range(d)):
            edge = x[off + c[a + 1]] - x[off + c[0]]
            for i in ti.static(range(d)):
                ds[i, a] = edge[i]
        return ds @ P.dm_inv[e]

    @ti.func
    def scatter(P: ti.template(), f: ti.template(), e, off, stress_e):
        """f[c_a] += node a's share of H = (-V) (P Dm^-T) (module docstring)."""
        c = P.cells[e]
        h = (-P.volume[e]) * (stress_e @ P.dm_inv[e].transpose())
        total = vec(0.0)
        for a in ti.static(range(d)):
            total += h[:, a]
        f[off + c[0]] += -total
        for a in ti.static(range(d)):
            f[off + c[a + 1]] += h[:, a]

    @ti.func
    def element_stress(P: ti.template(), F, e):
        """P(F) of element e: the law's, or after the radial return from its committed
        plastic state (`fem_plastic`)."""
        out = F
        if ti.static(plastic):
            out = plastic_stress(P, F, e)
        else:
            out = stress(F, P.mu, P.lam, P.alpha)
        return out

    @ti.func
    def elastic(P: ti.template(), x: ti.template(), f: ti.template(), off):
        """f = the elastic nodal forces -dU/dx at x (every node)."""
        for i in range(P.mass.shape[0]):
            f[off + i] = vec(0.0)
        for e in range(P.cells.shape[0]):
            scatter(P, f, e, off, element_stress(P, gradient(P, x, e, off), e))

    @ti.func
    def commit_all(P: ti.template(), x: ti.template()):
        """After an accepted step: every element's return at x made permanent (a plastic
        family only; nothing otherwise), as refsim's FemSystem.advance commits."""
        if ti.static(plastic):
            for e in range(P.cells.shape[0]):
                plastic_commit(P, gradient(P, x, e, 0), e)

    @ti.func
    def accel(P: ti.template(), x: ti.template(), a: ti.template(), off):
        elastic(P, x, a, off)
        for i in range(P.mass.shape[0]):
            a[off + i] = (a[off + i] + P.ext[i]) * P.inv_m[i]

    @ti.kernel
    def setup(P: pack_t):
        """Lumped masses rho V / (d + 1) per element node, inverse masses (0 on pinned
        nodes), ext = loads + m g."""
        ti.loop_config(serialize=True)
        for _ in range(1):
            for i in range(P.mass.shape[0]):
                P.mass[i] = 0.0
            for e in range(P.cells.shape[0]):
                m = P.density * P.volume[e] / (d + 1)
                for a in ti.static(range(d + 1)):
                    P.mass[P.cells[e][a]] += m
            for i in range(P.mass.shape[0]):
                P.inv_m[i] = 0.0
                if P.free_index[i] >= 0:
                    P.inv_m[i] = 1.0 / P.mass[i]
                P.ext[i] = P.loads[i] + P.mass[i] * P.gravity

    @ti.kernel
    def forces(P: pack_t, x: nd_vec, f: nd_vec):
        """f = the elastic nodal forces at x."""
        ti.loop_config(serialize=True)
        for _ in range(1):
            elastic(P, x, f, 0)

    @ti.kernel
    def commit(P: pack_t, x: nd_vec):
        """commit_all at x (the implicit steppers' accepted step)."""
        ti.loop_config(serialize=True)
        for _ in range(1):
            commit_all(P, x)

    @ti.kernel
    def explicit_euler(P: pack_t, x: nd_vec, v: nd_vec, a: nd_vec, h: f64, n: i32):
        """x += h v; v += h a(x) (both from the old state)."""
        ti.loop_config(serialize=True)
        for _ in range(n):
            accel(P, x, a, 0)
            for i in range(x.shape[0]):
                x[i] = x[i] + h * v[i]
                v[i] = v[i] + h * a[i]
            commit_all(P, x)

    @ti.kernel
    def symplectic_euler(P: pack_t, x: nd_vec, v: nd_vec, a: nd_vec, h: f64, n: i32):
        """Kick-drift: v += h a(x); x += h v."""
        ti.loop_config(serialize=True)
        for _ in range(n):
            accel(P, x, a, 0)
            for i in range(x.shape[0]):
                v[i] = v[i] + h * a[i]
                x[i] = x[i] + h * v[i]
            commit_all(P, x)

    @ti.kernel
    def velocity_verlet(P: pack_t, x: nd_vec, v: nd_vec, a: nd_vec, h: f64, n: i32,
                        start: i32):
        """vh = v + h/2 a; x += h vh; a = a(x); v = vh + h/2 a (no velocity-dependent force:
        no corrected kick). start = 1 first computes the carried a = a(x0) (one inlined force
        sweep in the kernel, not two: half the compile time)."""
        ti.loop_config(serialize=True)
        for step in range(n + start):
            if step >= start:
                for i in range(x.shape[0]):
                    v[i] = v[i] + (0.5 * h) * a[i]
                    x[i] = x[i] + h * v[i]
            accel(P, x, a, 0)
            if step >= start:
                for i in range(x.shape[0]):
                    v[i] = v[i] + (0.5 * h) * a[i]
                commit_all(P, x)

    @ti.func
    def accel_xv(P: ti.template(), x: ti.template(), v: ti.template(), a: ti.template(), off):
        """accel in the shared RK4 kernel's signature (no force here depends on v)."""
        accel(P, x, a, off)

    # classical RK4 with refsim's stage sums (network_kernels.make_rk4, shared with the spring
    # networks); the plastic commit after each step
    rk4 = make_rk4(pack_t, nd_vec, accel_xv, commit_all if plastic else None)

    @ti.kernel
    def stiffness(P: pack_t, x: nd_vec, K: ti.types.sparse_matrix_builder(), scale: f64,
                  diag: f64, w: nd_vec, kw: nd_f64):
        """scale K + diag M as triplets, K = -df/dx the tangent on the free dofs (free node k,
        component i -> k d + i): K_e[(a, i), (b, k)] = V sum_j dP(F; e_k grad_b^T)_ij
        grad_a,j, one directional derivative of the ELASTIC law per element dof (refsim's
        element_stiffness; a plastic law's tangent is its elastic law's), entered as
        scale (V value); M the lumped masses (no triplets where diag = 0). Also kw += K w
        on the free dofs (kw zeroed by the caller; w every node's, pinned ones' unused)."""
        ti.loop_config(serialize=True)
        for i in range(P.mass.shape[0]):
            row = P.free_index[i]
            if row >= 0 and diag != 0.0:
                for k in range(d):
                    K[row * d + k, row * d + k] += diag * P.mass[i]
        ti.loop_config(serialize=True)
        for e in range(P.cells.shape[0]):
            c = P.cells[e]
            F = gradient(P, x, e, 0)
            dmi = P.dm_inv[e]
            grads = ti.Matrix.zero(f64, d + 1, d)  # row a: grad phi_a (refsim's Elements.grad)
            for j in range(d):
                total = 0.0
                for r in range(d):
                    total += dmi[r, j]
                    grads[r + 1, j] = dmi[r, j]
                grads[0, j] = -total
            for q in range(d * (d + 1)):  # runtime loops, dynamic indices: a small kernel
                b, k = q // d, q % d
                dF = mat(0.0)
                for j in range(d):
                    dF[k, j] = grads[b, j]
                dP = differential(F, dF, P.mu, P.lam, P.alpha)
                col = P.free_index[c[b]]
                for a in range(d + 1):
                    row = P.free_index[c[a]]
                    if col >= 0 and row >= 0:
                        for i in range(d):
                            value = 0.0
                            for j in range(d):
                                value += dP[i, j] * grads[a, j]
                            entry = P.volume[e] * value
                            K[row * d + i, col * d + k] += scale * entry
                            kw[row * d + i] += entry * w[c[b]][k]

    return SimpleNamespace(pack_t=pack_t, vec=vec, mat=mat, mat3=ti.types.matrix(3, 3, f64),
                           cell=cell_type(d), setup=setup,
                           forces=forces, explicit_euler=explicit_euler,
                           symplectic_euler=symplectic_euler, velocity_verlet=velocity_verlet,
                           rk4=rk4, stiffness=stiffness, commit=commit)


def kernels(d: int, law: str, plane_strain: bool, plastic: bool = False):
    """The kernel family of (d, law, plane strain, plastic), made once per process."""
    made = runtime()["kernels"]
    key = ("fem", d, law, bool(plane_strain), bool(plastic))
    if key not in made:
        made[key] = make_kernels(d, law, bool(plane_strain), bool(plastic))
    return made[key]
