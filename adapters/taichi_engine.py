"""taichi (1.7.4) behind the refsim contract: the steppers are taichi kernels written here.

taichi has no integrator of its own ("whatever the kernel says; the adapter decides and
declares it", ENGINE_NOTES.md), so this adapter writes three, each as a `ti.func` with one
signature, driven by one generic kernel whose time loop runs inside the kernel:

- "symplectic_euler": kick-drift, v += h a(x, v); x += h v (refsim's `symplectic_euler`);
- "velocity_verlet": half kick, drift, half kick, acceleration carried between steps, and one
  corrected closing half kick when forces depend on velocity (refsim's `velocity_verlet`);
- "rk4": the classical 4-stage Runge-Kutta on (x, v) (refsim's `rk4`).

Physics is separate from the steppers (two `ti.func` accelerations): point masses under
gravity, linear drag f = -b v and springs to fixed anchors (f = -k (|d| - L0) u - c (v.u) u),
and hinged rods in generalized coordinates (theta'' = -(g/L) sin theta - (b/m) theta', the
angle mapped to the bob with refsim's hinge frame). Each body's motion is independent of the
others', so a step is a serial loop over bodies.

Colliding spheres (features "contacts", "walls"; `SphereSim`, symplectic_euler only) run in a
third kernel of the same shape. Per step, in this order: kick-drift as above (gravity, drag,
springs to anchors); a uniform grid over the bounding box (cell >= 2 r_max, counting sort of
the ids, a half stencil of neighbour cells so each pair is met once); contacts where
|d| <= (r_a + r_b)(1 + 1e-9) and sphere-wall gaps <= 1e-9 r (the slop catches touching
balls whose positions differ from touching by round-off, as in the cradle); each pair's
normal at the time of impact: backed up along its relative path over the last drift to
|d| = r_a + r_b (engine variant `overlap_normal`: the centre line of the overlapped pose, as
most engines); Gauss-Seidel passes over the contact list, each approaching contact getting
Newton's impulse J_n = -(1 + e) u.n / (1/m_a + 1/m_b) and Coulomb friction by Guendelman,
Bridson & Fedkiw 2003 (stick if the impulse stopping the slip is within mu J_n, else slide
with mu J_n), until a pass finds nothing approaching (at most 100 passes); then one pass of
positional projection out of overlap, split by inverse mass (velocities untouched). Every
impulse is a full binary impact, so at e = 1, mu = 0 energy is conserved to round-off
however many contacts a step holds, and the cradle's impacts propagate as the ideal sequence.
Walls' impulses are summed and observed as "wall_impulse".

ENGINE_NOTES.md facts applied (taichi 1.7.4), all reported in `Sim.settings()`:
- on import taichi writes to ~/.cache/taichi and tries a network version check:
  TI_SKIP_VERSION_CHECK=ON is set before the import and the offline kernel cache is pointed at
  a temp directory (and left off: `compile_s` is then always a cold JIT, comparable run to run);
- `default_fp` is f32 (5e-5 error on free fall): ti.init(default_fp=ti.f64), and every kernel
  argument and array is declared f64;
- the outermost loop of a kernel runs in parallel: the time loop carries
  `ti.loop_config(serialize=True)` (inner loops are serial), so runs are bit-reproducible;
- one launch per step from Python costs about 29 us (measured here: 50-90 us, growing with the
  number of array arguments) against ~0.05 us per step inside a kernel: the default runs the
  loop in the kernel; the engine variant "launch_per_step" launches once per step and records
  the launch cost it measured;
- the first call compiles (about 0.1 s cold) and each new template argument recompiles: build
  makes the first calls and reports their time as `compile_s`; state and parameters are
  ndarray/argpack arguments and n is a runtime i32, so no build or step recompiles anything;
- taichi uses every core by default: cpu_max_num_threads = 1 (a serial loop uses one anyway).
`fast_math` (default True) is turned off so LLVM may not reassociate float64 arithmetic.
`ti.init` runs once per process, lazily in the first `build` (a second ti.init would reset the
runtime and every kernel and array made before it). TI_ENABLE_PYBUF=0: with a
redirected sys.stdout (pytest, notebooks) taichi otherwise wraps every kernel call to flush a
print buffer, a per-launch cost these kernels (which never print) need not pay.
No `from __future__ import annotations` here: taichi reads `ti.template()` annotations as objects.
"""
import contextlib
import io
import math
import os
import tempfile
import time

import numpy as np

from refsim.engine import Engine, Sim
from refsim.integrators import get_integrator
from refsim.models.joints import cartesian_to_hinge, hinge_frame, hinge_to_cartesian
from refsim.models.sph import GAMMA as SPH_GAMMA
from refsim.models.sph import tait_density

INTEGRATORS = ("symplectic_euler", "velocity_verlet", "rk4")
VARIANTS = ("", "launch_per_step")
CONTACT_VARIANTS = VARIANTS + ("overlap_normal",)
FLUID_VARIANTS = VARIANTS + ("parallel",)
MAX_PASSES = 100  # Gauss-Seidel impulse passes per step, at most
APPROACH_TOL = 1e-12  # approaching: u.n < -APPROACH_TOL (|u_a| + |u_b|)
CONTACT_SLOP = 1e-9  # in contact: gap <= CONTACT_SLOP (r_a + r_b) (catches round-off touching)
CELLS_PER_SPHERE = 8  # grid array size 8 N + 64 (the cell size grows past 2 r_max to fit)
CONTACTS_PER_SPHERE = 16  # contact list size 16 N + 64; more is reported as a failure
SPH_CELLS_PER_PARTICLE = 4  # SPH grid array size 4 N + 64 (the cell grows past 2h to fit)
# CPU threads taichi may use (recorded in settings); REFSIM_TAICHI_THREADS overrides the 1
THREADS = int(os.environ.get("REFSIM_TAICHI_THREADS", "1") or 1)
OFFLINE_CACHE = False
CACHE_DIR = os.path.join(tempfile.gettempdir(),
                         f"refsim-taichi-cache-{getattr(os, 'getuid', lambda: 'user')()}")
NATIVE = {"symplectic_euler": "kernel kick_drift: v += h a(x, v); x += h v",
          "velocity_verlet": "kernel velocity_verlet: v += h/2 a; x += h v; a = a(x, v); "
                             "v += h/2 a (closing half kick corrected once when a depends on v)",
          "rk4": "kernel rk4: classical 4-stage Runge-Kutta on (x, v)"}
_I32_MAX = 2 ** 31 - 1

_RUNTIME: dict = {}  # the taichi module, ti.init facts, kernels: one per process


# ---------------------------------------------------------------------------------------------
# The taichi runtime: imported and initialised once per process, lazily
# ---------------------------------------------------------------------------------------------
def _import_taichi():
    """Import taichi with the version check off (it writes ~/.cache/taichi and calls the
    network otherwise, ENGINE_NOTES.md); its banner goes nowhere."""
    os.environ["TI_SKIP_VERSION_CHECK"] = "ON"
    os.environ["TI_ENABLE_PYBUF"] = "0"
    with contextlib.redirect_stdout(io.StringIO()):
        import taichi as ti
    return ti


def _runtime() -> dict:
    if _RUNTIME:
        return _RUNTIME
    ti = _import_taichi()
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        ti.init(arch=ti.cpu, default_fp=ti.f64, default_ip=ti.i32, cpu_max_num_threads=THREADS,
                fast_math=False, offline_cache=OFFLINE_CACHE, offline_cache_file_path=CACHE_DIR,
                log_level="warn")
    init_s = time.perf_counter() - t0
    lib = _define(ti)
    lib.update(_define_spheres(ti, lib))
    lib.update(_define_sph(ti, lib))
    _RUNTIME.update(ti=ti, init_s=init_s, lib=lib, kernels={}, compiled=set(),
                    launch_us={})
    return _RUNTIME


def _effective_config() -> dict:
    """What ti.init actually set, read back from taichi's own config."""
    ti = _RUNTIME["ti"]
    cfg = ti.lang.impl.current_cfg()
    return {"arch": str(cfg.arch).rsplit(".", 1)[-1],
            "default_fp": str(ti.lang.impl.get_runtime().default_fp),
            "cpu_max_num_threads": int(cfg.cpu_max_num_threads),
            "fast_math": bool(cfg.fast_math), "offline_cache": bool(cfg.offline_cache),
            "offline_cache_file_path": CACHE_DIR,
            "version_check": "skipped (TI_SKIP_VERSION_CHECK=ON set before import)",
            "python_print_buffer": "off (TI_ENABLE_PYBUF=0: no flush after each launch)",
            "runtime_init_s": _RUNTIME["init_s"]}


# ---------------------------------------------------------------------------------------------
# Kernels (defined once taichi is imported)
# ---------------------------------------------------------------------------------------------
def _define(ti) -> dict:
    """Types, physics (`*_accel`), steppers and the kernel factories, as a dict."""
    f64 = ti.f64
    vec3 = ti.types.vector(3, f64)
    nd_vec3 = ti.types.ndarray(dtype=vec3, ndim=1)
    nd_f64 = ti.types.ndarray(dtype=f64, ndim=1)
    nd_i32 = ti.types.ndarray(dtype=ti.i32, ndim=1)
    particles_t = ti.types.argpack(inv_m=nd_f64, gravity=vec3, drag=f64, spring_body=nd_i32,
                                   spring_anchor=nd_vec3, spring_k=nd_f64, spring_rest=nd_f64,
                                   spring_c=nd_f64, velocity_dependent=ti.i32)
    hinges_t = ti.types.argpack(g_over_l=nd_f64, drag_over_m=nd_f64, velocity_dependent=ti.i32)

    # -- physics: acceleration of element i at (x, v) ------------------------------------------
    @ti.func
    def particle_accel(P: ti.template(), i, x, v):
        """Springs to fixed anchors (-k (|d| - L0) u - c (v.u) u), drag -b v, then f/m + g."""
        f = vec3(0.0, 0.0, 0.0)
        for s in range(P.spring_body.shape[0]):
            if P.spring_body[s] == i:
                d = x - P.spring_anchor[s]
                length = d.norm()
                u = vec3(0.0, 0.0, 0.0)
                if length > 0.0:
                    u = d / length
                f += -(P.spring_k[s] * (length - P.spring_rest[s])) * u
                f -= P.spring_c[s] * v.dot(u) * u
        f -= P.drag * v
        return f * P.inv_m[i] + P.gravity

    @ti.func
    def hinge_accel(P: ti.template(), i, q, qd):
        """theta'' = -(g/L) sin theta - (b/m) theta' for rod i."""
        return -P.g_over_l[i] * ti.sin(q) - P.drag_over_m[i] * qd

    # -- steppers: (x, v, a) -> (x, v, a) one step of h later; a is carried (Verlet) -----------
    @ti.func
    def kick_drift(accel: ti.template(), P: ti.template(), i, x, v, a, h):
        a1 = accel(P, i, x, v)
        v1 = v + h * a1
        return x + h * v1, v1, a1

    @ti.func
    def velocity_verlet(accel: ti.template(), P: ti.template(), i, x, v, a, h):
        vh = v + (0.5 * h) * a
        x1 = x + h * vh
        a1 = accel(P, i, x1, vh)
        v1 = vh + (0.5 * h) * a1
        if P.velocity_dependent:
            a1 = accel(P, i, x1, v1)
            v1 = vh + (0.5 * h) * a1
        return x1, v1, a1

    @ti.func
    def rk4(accel: ti.template(), P: ti.template(), i, x, v, a, h):
        k1x, k1v = v, accel(P, i, x, v)
        k2x = v + (0.5 * h) * k1v
        k2v = accel(P, i, x + (0.5 * h) * k1x, k2x)
        k3x = v + (0.5 * h) * k2v
        k3v = accel(P, i, x + (0.5 * h) * k2x, k3x)
        k4x = v + h * k3v
        k4v = accel(P, i, x + h * k3x, k4x)
        x1 = x + (h / 6.0) * k1x + (h / 3.0) * k2x + (h / 3.0) * k3x + (h / 6.0) * k4x
        v1 = v + (h / 6.0) * k1v + (h / 3.0) * k2v + (h / 3.0) * k3v + (h / 6.0) * k4v
        return x1, v1, k1v

    # -- kernel factories: one compiled kernel per (system, stepper) per process --------------
    def advance_kernel(stepper, accel, state_t, pack_t):
        @ti.kernel
        def advance(x: state_t, v: state_t, a: state_t, P: pack_t, h: f64, n: ti.i32):
            ti.loop_config(serialize=True)  # the time loop is the outermost loop: keep it serial
            for _ in range(n):
                for i in range(x.shape[0]):
                    x1, v1, a1 = stepper(accel, P, i, x[i], v[i], a[i], h)
                    x[i], v[i], a[i] = x1, v1, a1
        return advance

    def accel_kernel(accel, state_t, pack_t):
        @ti.kernel
        def start(x: state_t, v: state_t, a: state_t, P: pack_t):
            ti.loop_config(serialize=True)
            for i in range(x.shape[0]):
                a[i] = accel(P, i, x[i], v[i])
        return start

    return {"vec3": vec3, "systems": {"particles": (particle_accel, nd_vec3, particles_t),
                                      "hinges": (hinge_accel, nd_f64, hinges_t)},
            "steppers": {"symplectic_euler": kick_drift, "velocity_verlet": velocity_verlet,
                         "rk4": rk4},
            "advance_kernel": advance_kernel, "accel_kernel": accel_kernel}


def _define_spheres(ti, lib) -> dict:
    """Colliding spheres: the contact pack type and one kernel whose serialised time loop does,
    per step: kick-drift (`particle_accel`: gravity, drag, springs to anchors), the grid broad
    phase, contact normals, Gauss-Seidel impulses (Newton restitution, Guendelman friction),
    then positional projection. A contact is (a, b, n) with n the unit normal from a to b;
    a = -1 - k stands for wall k (b is then the sphere)."""
    f64, i32 = ti.f64, ti.i32
    vec3, ivec3 = lib["vec3"], ti.types.vector(3, i32)
    nd_vec3 = ti.types.ndarray(dtype=vec3, ndim=1)
    nd_f64 = ti.types.ndarray(dtype=f64, ndim=1)
    nd_i32 = ti.types.ndarray(dtype=i32, ndim=1)
    nd_i64 = ti.types.ndarray(dtype=ti.i64, ndim=1)
    particle_accel, particles_t = lib["systems"]["particles"][0], lib["systems"]["particles"][2]
    contacts_t = ti.types.argpack(
        radius=nd_f64, inv_inertia=nd_f64, wall_point=nd_vec3, wall_normal=nd_vec3,
        n_walls=i32, restitution=f64, friction=f64, slop=f64, approach_tol=f64, cell_min=f64,
        max_passes=i32, toi_normal=i32, cell_count=nd_i32, cell_start=nd_i32, cell_of=nd_i32,
        order=nd_i32, sorted_x=nd_vec3, contact_a=nd_i32, contact_b=nd_i32, contact_n=nd_vec3,
        wall_impulse=nd_vec3, stats=nd_i64, depth_max=nd_f64)

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

    # -- impulses -------------------------------------------------------------------------------
    @ti.func
    def contact_impulse(u, n, kn, kt, e, mu):
        """Impulse on b for a relative contact velocity u (b minus a), normal n. Sphere
        contacts decouple: du = kn J_n n + kt J_t (kn = 1/m_a + 1/m_b, kt = kn + r_a^2/I_a +
        r_b^2/I_b). Newton: J_n = -(1 + e) u.n / kn. Coulomb (Guendelman 2003): stick with
        J_t = -u_t / kt when |J_t| <= mu J_n, else slide with mu J_n against u_t."""
        un = u.dot(n)
        jn = -(1.0 + e) * un / kn
        J = jn * n
        if mu > 0.0:
            ut = u - un * n
            jt = -ut / kt
            if jt.norm() <= mu * jn:
                J += jt
            else:
                J -= (mu * jn / ut.norm()) * ut
        return J

    @ti.func
    def apply_contact(v: ti.template(), w: ti.template(), P: ti.template(), C: ti.template(), c):
        """One Gauss-Seidel update of contact c when it approaches (u.n below -approach_tol
        times the contact points' speeds); returns 1 if an impulse was applied."""
        a, b, n = C.contact_a[c], C.contact_b[c], C.contact_n[c]
        rb = C.radius[b]
        ub = v[b] - rb * w[b].cross(n)
        ra, inv_ma, inv_ia, ua = 0.0, 0.0, 0.0, vec3(0.0, 0.0, 0.0)
        if a >= 0:
            ra, inv_ma, inv_ia = C.radius[a], P.inv_m[a], C.inv_inertia[a]
            ua = v[a] + ra * w[a].cross(n)
        u = ub - ua
        hit = 0
        if u.dot(n) < -C.approach_tol * (ub.norm() + ua.norm()):
            inv_mb, inv_ib = P.inv_m[b], C.inv_inertia[b]
            kn = inv_ma + inv_mb
            J = contact_impulse(u, n, kn, kn + ra * ra * inv_ia + rb * rb * inv_ib,
                                C.restitution, C.friction)
            v[b] += inv_mb * J
            w[b] -= (rb * inv_ib) * n.cross(J)
            if a >= 0:
                v[a] -= inv_ma * J
                w[a] -= (ra * inv_ia) * n.cross(J)
            else:
                C.wall_impulse[0] += J
            hit = 1
        return hit

    @ti.func
    def resolve(v: ti.template(), w: ti.template(), P: ti.template(), C: ti.template(), nc):
        """Gauss-Seidel passes over the contact list until a pass finds no approaching
        contact, at most C.max_passes. Returns (passes, impulses, still approaching)."""
        passes, impulses, active = 0, 0, 0
        for _ in range(C.max_passes):
            active = 0
            for c in range(nc):
                active += apply_contact(v, w, P, C, c)
            passes += 1
            impulses += active
            if active == 0:
                break
        return passes, impulses, active

    @ti.func
    def project(x: ti.template(), P: ti.template(), C: ti.template(), nc):
        """One pass, contact by contact: overlapping spheres are pushed apart along the
        current centre line, the depth split by inverse mass; a sphere in a wall is moved out
        along the wall normal. Velocities are untouched. C.depth_max keeps the deepest
        overlap met (before its projection)."""
        for c in range(nc):
            a, b = C.contact_a[c], C.contact_b[c]
            if a >= 0:
                d = x[b] - x[a]
                dist = d.norm()
                depth = C.radius[a] + C.radius[b] - dist
                if depth > 0.0 and dist > 0.0:
                    C.depth_max[0] = ti.max(C.depth_max[0], depth)
                    share = P.inv_m[a] / (P.inv_m[a] + P.inv_m[b])
                    x[a] -= (depth * share / dist) * d
                    x[b] += (depth * (1.0 - share) / dist) * d
            else:
                nw = C.wall_normal[-1 - a]
                gap = (x[b] - C.wall_point[-1 - a]).dot(nw) - C.radius[b]
                if gap < 0.0:
                    C.depth_max[0] = ti.max(C.depth_max[0], -gap)
                    x[b] -= gap * nw

    @ti.func
    def record(C: ti.template(), nc, passes, impulses, active):
        """stats: 0 dropped contacts, 1 steps without a grid (non-finite), 2 most passes in a
        step, 3 steps ending at the pass cap with a contact still approaching, 4 impulses,
        5 contacts found, 6 steps."""
        C.stats[2] = ti.max(C.stats[2], passes)
        if active > 0:
            C.stats[3] += 1
        C.stats[4] += impulses
        C.stats[5] += nc
        C.stats[6] += 1

    @ti.kernel
    def advance_spheres(x: nd_vec3, v: nd_vec3, w: nd_vec3, P: particles_t, C: contacts_t,
                        h: f64, n: ti.i32):
        ti.loop_config(serialize=True)  # the time loop: serial, and so is everything inside
        for _ in range(n):
            for i in range(x.shape[0]):  # kick-drift, refsim's symplectic_euler
                v[i] = v[i] + h * particle_accel(P, i, x[i], v[i])
                x[i] = x[i] + h * v[i]
            nc = find_contacts(x, v, C, h)
            passes, impulses, active = resolve(v, w, P, C, nc)
            project(x, P, C, nc)
            record(C, nc, passes, impulses, active)

    return {"contacts_t": contacts_t, "advance_spheres": advance_spheres}


def _define_sph(ti, lib) -> dict:
    """2D WCSPH (`refsim.models.sph`'s model and parameters) as taichi functions and two
    kernels: `start_sph` (grid, pressures, a(x0, rho0)) and `advance_sph`, whose serialised
    time loop runs refsim's kick-drift-kick step with the trapezoid density drift.

    Particles: fluid 0..n_fluid-1, then the fixed wall (dummy) particles, in one position and
    one velocity array (walls at rest, v = 0). Neighbours: a uniform grid over the bounding
    box of all particles, cell >= 2h, rebuilt after every drift by a serial counting sort
    (ids in index order within a cell); each particle gathers its own sums over the 3 x 3
    cells around it (every sum is written by its owner: no atomics, no scatter). Pairs are
    those with r < 2h, i != j; the expressions follow the numpy model term by term, so the two
    engines differ in summation order only."""
    f64, i32 = ti.f64, ti.i32
    vec2, ivec2 = ti.types.vector(2, f64), ti.types.vector(2, i32)
    nd_vec2 = ti.types.ndarray(dtype=vec2, ndim=1)
    nd_f64 = ti.types.ndarray(dtype=f64, ndim=1)
    nd_i32 = ti.types.ndarray(dtype=i32, ndim=1)
    nd_i64 = ti.types.ndarray(dtype=ti.i64, ndim=1)
    sph_t = ti.types.argpack(
        n_fluid=i32, no_slip=i32, tension=i32, mass=f64, h=f64, rho0=f64, c0=f64, alpha=f64,
        delta=f64, gravity=vec2, cell_min=f64,
        rho=nd_f64, p=nd_f64, drho=nd_f64, diffused=nd_f64, acc=nd_vec2, cell_count=nd_i32,
        cell_start=nd_i32,
        cell_of=nd_i32, order=nd_i32, grid=nd_f64, dims=nd_i32, stats=nd_i64)
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

    # -- kernels -------------------------------------------------------------------------------
    @ti.kernel
    def start_sph(x: nd_vec2, v: nd_vec2, S: sph_t):
        ti.loop_config(serialize=True)
        for _ in range(1):
            build_grid(x, S)
            accelerations(x, v, S)

    @ti.kernel
    def advance_sph(x: nd_vec2, v: nd_vec2, S: sph_t, dt: f64, n: ti.i32):
        """Per step (refsim.models.sph.WCSPH.step): v+ = v + dt/2 a; D0 = D(x, v+) and the
        delta-SPH Dd(x, rho) on the grid of x; x' = x + dt v+; grid of x';
        rho' = rho + dt/2 (D0 + D(x', v+)) + dt Dd;
        a' = a(x', rho'); v' = v+ + dt/2 a'."""
        ti.loop_config(serialize=True)  # the time loop: serial, and so is everything inside
        for _ in range(n):
            half = 0.5 * dt
            nf = S.n_fluid
            for i in range(nf):
                v[i] = v[i] + half * S.acc[i]
            for i in range(nf):
                S.drho[i], S.diffused[i] = density_rates(x, v, S, i, True)
            for i in range(nf):
                x[i] = x[i] + dt * v[i]
            build_grid(x, S)
            for i in range(nf):
                S.rho[i] = S.rho[i] + half * (S.drho[i] + density_rates(x, v, S, i, False)[0]) + (
                    dt * S.diffused[i])
            accelerations(x, v, S)
            for i in range(nf):
                v[i] = v[i] + half * S.acc[i]
            S.stats[1] += 1

    @ti.kernel
    def step_sph_parallel(x: nd_vec2, v: nd_vec2, S: sph_t, dt: f64):
        """One step of `advance_sph`, each stage a top-level loop that taichi runs on
        cpu_max_num_threads threads: every particle writes only its own sums (gathers, no
        atomics), and the counting sort stays serial, so the bits do not depend on the
        thread count or schedule."""
        half = 0.5 * dt
        for i in range(S.n_fluid):
            v[i] = v[i] + half * S.acc[i]
        for i in range(S.n_fluid):
            S.drho[i], S.diffused[i] = density_rates(x, v, S, i, True)
        for i in range(S.n_fluid):
            x[i] = x[i] + dt * v[i]
        ti.loop_config(serialize=True)
        for _ in range(1):
            build_grid(x, S)
        for i in range(S.n_fluid):
            S.rho[i] = S.rho[i] + half * (S.drho[i] + density_rates(x, v, S, i, False)[0]) + (
                dt * S.diffused[i])
        for i in range(S.n_fluid):
            S.p[i] = fluid_pressure(S, i)
        for w in range(S.n_fluid, x.shape[0]):
            wall_pressure(x, S, w)
        for i in range(S.n_fluid):
            S.acc[i] = momentum(x, v, S, i)
        for i in range(S.n_fluid):
            v[i] = v[i] + half * S.acc[i]
        ti.loop_config(serialize=True)
        for _ in range(1):
            S.stats[1] += 1

    def advance_sph_parallel(x, v, S, dt, n):
        for _ in range(n):
            step_sph_parallel(x, v, S, dt)

    return {"vec2": vec2, "sph_t": sph_t, "start_sph": start_sph, "advance_sph": advance_sph,
            "step_sph_parallel": step_sph_parallel, "advance_sph_parallel": advance_sph_parallel}


def _kernels(system: str, integrator: str):
    """(start, advance) kernels for a system and stepper, made once per process."""
    rt = _runtime()
    key = (system, integrator)
    if key not in rt["kernels"]:
        lib = rt["lib"]
        if system == "spheres":  # one kernel (kick-drift + contacts), no start kernel
            rt["kernels"][key] = (None, lib["advance_spheres"])
            return rt["kernels"][key]
        if system == "sph":  # start: grid and a(x0, rho0); advance: the time loop
            rt["kernels"][key] = (lib["start_sph"], lib["advance_sph"])
            return rt["kernels"][key]
        accel, state_t, pack_t = lib["systems"][system]
        rt["kernels"][key] = (lib["accel_kernel"](accel, state_t, pack_t),
                              lib["advance_kernel"](lib["steppers"][integrator], accel, state_t,
                                                    pack_t))
    return rt["kernels"][key]


def _launch_overhead_us(advance, args) -> float:
    """Cost of one kernel launch from Python (n = 0 steps): the price of `launch_per_step`.
    Measured once per process and kernel, best of 10 rounds of 100 launches."""
    measured = _RUNTIME["launch_us"]
    if advance not in measured:
        best = math.inf
        for _ in range(10):
            t0 = time.perf_counter()
            for _ in range(100):
                advance(*args, 0)
            best = min(best, (time.perf_counter() - t0) / 100)
        measured[advance] = best * 1e6
    return measured[advance]


# ---------------------------------------------------------------------------------------------
# Engine
# ---------------------------------------------------------------------------------------------
class TaichiEngine(Engine):
    name = "taichi"
    package = "taichi"
    capabilities = frozenset({"gravity", "springs", "joints", "drag", "contacts", "walls",
                              "fluid"})
    dims = (2, 3)
    integrators = INTEGRATORS

    def available(self) -> bool:
        try:
            _import_taichi()
        except Exception:
            return False
        return True

    def variants(self, scene):
        if scene.fluid is not None:
            return FLUID_VARIANTS
        return CONTACT_VARIANTS if _has_contacts(scene) else VARIANTS

    def supports(self, scene, integrator=None):
        reason = super().supports(scene, integrator)
        if reason:
            return reason
        if scene.fluid is not None:
            return _fluid_refusal(scene, integrator)
        if any(s.other is not None for s in scene.springs):
            return ("taichi adapter: springs between two bodies are not modelled "
                    "(only springs to fixed anchors)")
        if _has_contacts(scene):
            return _contact_refusal(scene, integrator)
        if not scene.joints:
            return None
        jointed = {j.body for j in scene.joints}
        if len(jointed) != len(scene.joints) or len(jointed) != len(scene.bodies):
            return "taichi adapter: hinges need exactly one rod per body (generalized coordinates)"
        if scene.springs:
            return "taichi adapter: springs on a hinged body are not modelled"
        return None

    def build(self, scene, dt, integrator, variant=""):
        dt = float(dt)
        if not math.isfinite(dt) or dt <= 0:
            raise ValueError(f"dt must be a finite number > 0, got {dt}")
        if integrator not in INTEGRATORS:
            raise ValueError(f"taichi integrator must be one of {list(INTEGRATORS)}, "
                             f"got {integrator!r}")
        if variant not in self.variants(scene):
            raise ValueError(f"taichi variant must be one of {list(self.variants(scene))}, "
                             f"got {variant!r}")
        reason = self.supports(scene, integrator)
        if reason:
            raise ValueError(reason)
        if scene.fluid is not None:
            return FluidSim(scene, dt, integrator, variant)
        cls = SphereSim if _has_contacts(scene) else HingeSim if scene.joints else ParticleSim
        return cls(scene, dt, integrator, variant)


def _has_contacts(scene) -> bool:
    return bool({"contacts", "walls"} & scene.features())


def _fluid_refusal(scene, integrator):
    """Why a fluid scene cannot be simulated faithfully here, or None."""
    if scene.bodies or scene.springs or scene.joints or scene.contact is not None:
        return ("taichi adapter: a fluid scene holds the fluid and its tank only (bodies, "
                "springs, joints or contacts with SPH are not modelled)")
    if scene.linear_drag > 0:
        return "taichi adapter: linear drag on SPH particles is not modelled"
    if integrator is not None and integrator != "velocity_verlet":
        return ("taichi adapter: fluid scenes step with kick-drift-kick SPH "
                "('velocity_verlet'), as refsim's")
    return None


def _contact_refusal(scene, integrator):
    """Why a contact scene cannot be simulated faithfully here, or None."""
    if scene.contact is None:
        return "taichi adapter: walls need a contact model (scene.contact) for their restitution"
    if scene.joints:
        return "taichi adapter: contacts with hinged bodies are not modelled"
    if integrator is not None and integrator != "symplectic_euler":
        return ("taichi adapter: contact scenes step with symplectic_euler only (kick-drift, "
                "then impulses; a multi-stage stepper would need the impact located in time)")
    if any(b.radius <= 0 for b in scene.bodies):
        return "taichi adapter: contacts need every body to be a sphere of radius > 0"
    if scene.contact.friction > 0 and any(b.inertia <= 0 for b in scene.bodies):
        return "taichi adapter: friction needs every sphere's moment of inertia > 0"
    return None


# ---------------------------------------------------------------------------------------------
# Sims
# ---------------------------------------------------------------------------------------------
class _KernelSim(Sim):
    """Bookkeeping shared by every system: the kernel arguments (state ndarrays and argpacks,
    everything before h and n), the kernels, timing of the first (compiling) calls, stepping
    in-kernel or one launch per step."""

    system = ""

    def __init__(self, dt, integrator, variant, args):
        rt = _runtime()
        ti = rt["ti"]
        self.dt, self.integrator, self.variant, self.steps = dt, integrator, variant, 0
        self.stepper = get_integrator(integrator)
        self.args = tuple(args)
        start, self.advance = _kernels(self.system, integrator)
        key = (self.system, integrator)
        self.cold = key not in rt["compiled"]
        t0 = time.perf_counter()
        if start is not None:
            start(*self.args)  # a0 = a(x0, v0): Verlet's carried acceleration
        self.advance(*self.args, dt, 0)  # compiles on first use
        ti.sync()
        self.compile_s = time.perf_counter() - t0
        rt["compiled"].add(key)
        self.launch_us = (_launch_overhead_us(self.advance, (*self.args, dt))
                          if variant == "launch_per_step" else None)

    def step(self, n):
        n = int(n)
        if n < 0:
            raise ValueError(f"n must be >= 0, got {n}")
        args = (*self.args, self.dt)
        if self.variant == "launch_per_step":
            for _ in range(n):
                self.advance(*args, 1)
        else:
            done = 0
            while done < n:
                chunk = min(n - done, _I32_MAX)
                self.advance(*args, chunk)
                done += chunk
        self.steps += n

    @property
    def t(self) -> float:
        return self.steps * self.dt

    def base_settings(self) -> dict:
        described = self.stepper.describe()
        loop = ("one kernel launch per step from Python" if self.variant == "launch_per_step"
                else "time loop inside one kernel, ti.loop_config(serialize=True)")
        out = {"integrator": {**described, "native": NATIVE[self.integrator]},
               "dtype": "float64", "threads": THREADS, **_effective_config(),
               "time_loop": loop, "kernel_args": "ndarray + argpack, n a runtime i32 "
               "(no recompilation per build or per step count)",
               "compile": "cold JIT in this build" if self.cold else
               "kernels already compiled in this process (launch time only)"}
        if self.launch_us is not None:
            out["per_step_python_call_us"] = self.launch_us
            out["per_step_python_call"] = ("one kernel launch per step: its measured cost "
                                           "(ENGINE_NOTES: about 29 us) is part of step_s")
        else:
            out["per_step_python_call"] = "none (one launch per Sim.step(n) call)"
        return out

    def close(self):
        self.args = ()


class ParticleSim(_KernelSim):
    system = "particles"

    def __init__(self, scene, dt, integrator, variant):
        ti = _runtime()["ti"]
        self.scene = scene
        n = len(scene.bodies)
        state = [ti.ndarray(_RUNTIME["lib"]["vec3"], n) for _ in range(3)]
        state[0].from_numpy(scene.positions)
        state[1].from_numpy(scene.velocities)
        state[2].from_numpy(np.zeros((n, 3)))
        self.x, self.v = state[0], state[1]
        super().__init__(dt, integrator, variant, (*state, self._pack(ti, scene)))

    @staticmethod
    def _pack(ti, scene):
        lib = _RUNTIME["lib"]
        springs = scene.springs
        ns = max(1, len(springs))  # a dummy spring on body -1 when there are none
        arrays = {"inv_m": 1.0 / scene.masses,
                  "spring_body": np.array([s.body for s in springs] or [-1], np.int32),
                  "spring_anchor": np.array([s.anchor for s in springs] or [(0.0,) * 3]),
                  "spring_k": np.array([s.stiffness for s in springs] or [0.0]),
                  "spring_rest": np.array([s.rest_length for s in springs] or [0.0]),
                  "spring_c": np.array([s.damping for s in springs] or [0.0])}
        nd = {}
        for key, arr in arrays.items():
            if key == "spring_anchor":
                nd[key] = ti.ndarray(lib["vec3"], ns)
            else:
                nd[key] = ti.ndarray(ti.i32 if arr.dtype == np.int32 else ti.f64, len(arr))
            nd[key].from_numpy(arr)
        velocity_dependent = int(scene.linear_drag > 0 or any(s.damping > 0 for s in springs))
        pack_t = lib["systems"]["particles"][2]
        return pack_t(gravity=lib["vec3"](*scene.gravity), drag=scene.linear_drag,
                      velocity_dependent=velocity_dependent, **nd)

    def observe(self):
        return {"t": self.t, "x": self.x.to_numpy().reshape(-1, 3),
                "v": self.v.to_numpy().reshape(-1, 3)}

    def settings(self):
        stages = [name for name, on in (("gravity", any(self.scene.gravity)),
                                        ("drag", self.scene.linear_drag > 0),
                                        ("springs", bool(self.scene.springs))) if on]
        return {**self.base_settings(), "formulation": "cartesian point masses",
                "stages": stages + [f"integrate:{self.integrator}"],
                "springs": "to fixed anchors, -k (|d| - L0) u - c (v.u) u",
                "drag": "linear, f = -b v, applied exactly in the force"}


class HingeSim(_KernelSim):
    system = "hinges"

    def __init__(self, scene, dt, integrator, variant):
        ti = _runtime()["ti"]
        self.scene = scene
        frames = [hinge_frame(j.axis, scene.gravity) for j in scene.joints]
        self.d = np.array([f[0] for f in frames])
        self.s = np.array([f[1] for f in frames])
        self.bodies = np.array([j.body for j in scene.joints])
        self.anchor = np.array([j.anchor for j in scene.joints])
        self.length = np.array([j.length for j in scene.joints])
        x0, v0 = scene.positions[self.bodies], scene.velocities[self.bodies]
        theta0, omega0 = np.array([cartesian_to_hinge(x0[i], v0[i], self.anchor[i],
                                                      self.length[i], self.d[i], self.s[i])
                                   for i in range(len(self.bodies))]).T
        masses = scene.masses[self.bodies]
        g_plane = np.array([f[2] for f in frames])
        n = len(self.bodies)
        arrays = [np.asarray(theta0, float), np.asarray(omega0, float), np.zeros(n),
                  g_plane / self.length, np.full(n, scene.linear_drag) / masses]
        nd = [ti.ndarray(ti.f64, n) for _ in arrays]
        for a, arr in zip(nd, arrays):
            a.from_numpy(arr)
        pack = _RUNTIME["lib"]["systems"]["hinges"][2](
            g_over_l=nd[3], drag_over_m=nd[4], velocity_dependent=int(scene.linear_drag > 0))
        self.x, self.v = nd[0], nd[1]
        super().__init__(dt, integrator, variant, (*nd[:3], pack))

    def observe(self):
        theta, omega = self.x.to_numpy(), self.v.to_numpy()
        xb, vb = hinge_to_cartesian(theta, omega, self.anchor, self.length, self.d, self.s)
        x, v = self.scene.positions.copy(), self.scene.velocities.copy()
        x[self.bodies], v[self.bodies] = xb, vb
        return {"t": self.t, "x": x, "v": v, "constraint": np.zeros(len(self.bodies))}

    def settings(self):
        stages = ["gravity"] if any(self.scene.gravity) else []
        if self.scene.linear_drag > 0:
            stages.append("drag")
        return {**self.base_settings(), "formulation": "generalized coordinate (hinge angle)",
                "stages": stages + ["hinge_generalized", f"integrate:{self.integrator}"],
                "hinge_frame": {"d": self.d.tolist(), "s": self.s.tolist()},
                "constraint": "exact by construction (rod length errors reported as 0)"}


class SphereSim(_KernelSim):
    """Spheres with contacts (and walls): one kernel per `step(n)`, its time loop serialised.
    Per step: kick-drift (v += h a(x, v); x += h v, refsim's `symplectic_euler`: gravity,
    drag, springs to anchors), then contacts on the drifted positions: broad phase on a
    uniform grid, contact normals, Gauss-Seidel impulse passes, positional projection."""

    system = "spheres"

    def __init__(self, scene, dt, integrator, variant):
        ti = _runtime()["ti"]
        self.scene = scene
        self.x, self.v, self.w = (_ndarray(ti, a) for a in (
            scene.positions, scene.velocities, scene.angular_velocities))
        self.nd = self._contact_arrays(ti, scene)
        lib = _RUNTIME["lib"]
        scalars = {"n_walls": len(scene.walls), "restitution": scene.contact.restitution,
                   "friction": scene.contact.friction, "slop": CONTACT_SLOP,
                   "approach_tol": APPROACH_TOL, "cell_min": self.cell_min(scene),
                   "max_passes": MAX_PASSES, "toi_normal": int(variant != "overlap_normal")}
        contacts = lib["contacts_t"](**self.nd, **scalars)
        particles = ParticleSim._pack(ti, scene)
        super().__init__(dt, integrator, variant, (self.x, self.v, self.w, particles, contacts))

    @staticmethod
    def cell_min(scene) -> float:
        """Smallest grid cell: the largest contact reach, 2 r_max (1 + slop), rounded up."""
        return 2.0 * float(scene.radii.max()) * (1.0 + 2.0 * CONTACT_SLOP)

    @staticmethod
    def _contact_arrays(ti, scene) -> dict:
        """Per-sphere data (radius, 1/I from the scene: never recomputed), walls (one dummy
        when none), grid and contact-list scratch, wall impulse and counters."""
        n, walls = len(scene.bodies), scene.walls
        inertia = scene.inertias
        cells, cap = CELLS_PER_SPHERE * n + 64, CONTACTS_PER_SPHERE * n + 64
        arrays = {"radius": scene.radii,
                  "inv_inertia": np.divide(1.0, inertia, out=np.zeros(n), where=inertia > 0),
                  "wall_point": np.array([w.point for w in walls] or [(0.0, 0.0, 0.0)]),
                  "wall_normal": np.array([w.normal for w in walls] or [(0.0, 0.0, 1.0)]),
                  "cell_count": np.zeros(cells, np.int32), "cell_start": np.zeros(cells, np.int32),
                  "cell_of": np.zeros(n, np.int32), "order": np.zeros(n, np.int32),
                  "sorted_x": np.zeros((n, 3)),
                  "contact_a": np.zeros(cap, np.int32), "contact_b": np.zeros(cap, np.int32),
                  "contact_n": np.zeros((cap, 3)), "wall_impulse": np.zeros((1, 3)),
                  "stats": np.zeros(len(STATS), np.int64), "depth_max": np.zeros(1)}
        return {key: _ndarray(ti, arr) for key, arr in arrays.items()}

    def step(self, n):
        super().step(n)
        stats = self.contact_stats()
        if stats["dropped_contacts"]:
            self.failure = (f"contact list full: {stats['dropped_contacts']} contacts dropped "
                            f"(capacity {self.nd['contact_a'].shape[0]}) by t={self.t:.6g}")
        elif stats["steps_without_grid"]:
            self.failure = f"non-finite positions: contacts skipped by t={self.t:.6g}"

    def contact_stats(self) -> dict:
        """Counters since build (see STATS) and the deepest overlap met before projection."""
        out = dict(zip(STATS, (int(c) for c in self.nd["stats"].to_numpy())))
        out["depth_max"] = float(self.nd["depth_max"].to_numpy()[0])
        return out

    def observe(self):
        return {"t": self.t, "x": self.x.to_numpy().reshape(-1, 3),
                "v": self.v.to_numpy().reshape(-1, 3), "w": self.w.to_numpy().reshape(-1, 3),
                "wall_impulse": self.nd["wall_impulse"].to_numpy().reshape(3)}

    def settings(self):
        contact = self.scene.contact
        normal = ("centre line at detection (the penetrating configuration), as most engines"
                  if self.variant == "overlap_normal" else
                  "at the time of impact on the straight relative path of the last drift "
                  "(|d - s v_rel| = r_a + r_b, |s| <= dt), else the centre line")
        stages = [name for name, on in (("gravity", any(self.scene.gravity)),
                                        ("drag", self.scene.linear_drag > 0),
                                        ("springs", bool(self.scene.springs))) if on]
        integ = {**self.base_settings()["integrator"],
                 "note": "kick-drift between impacts; impulses after the drift"}
        return {**self.base_settings(), "integrator": integ,
                "formulation": "spheres with impulse contacts",
                "stages": stages + ["integrate:symplectic_euler", "broad_phase:grid",
                                    "contact_normals", "impulses:gauss_seidel",
                                    "projection"],
                "step_order": "kick v += h a(x, v); drift x += h v; detect on the drifted "
                              "positions; impulse passes; positional projection",
                "contact_model": "impulse",
                "restitution": contact.restitution,
                "restitution_mapping": "e used as is in Newton's law along n: J_n = -(1 + e) "
                                       "(u.n) / (1/m_a + 1/m_b) (no per-body product)",
                "friction": contact.friction,
                "friction_model": "Coulomb, Guendelman et al. 2003: stick (J_t = -u_t / k_t, "
                                  "k_t = 1/m_a + 1/m_b + r_a^2/I_a + r_b^2/I_b) when |J_t| <= "
                                  "mu J_n, else slide with mu J_n against u_t",
                "inertia": "from the scene (2/5 m r^2 for the case's solid spheres), never "
                           "recomputed",
                "solver": {"kind": "sequential (Gauss-Seidel) pair impulses over the contact "
                                   "list in a fixed order", "max_passes": MAX_PASSES,
                           "stop": "a pass with no approaching contact",
                           "approaching": f"u.n < -{APPROACH_TOL:g} (|u_a| + |u_b|)"},
                "detection": "discrete" if self.variant == "overlap_normal" else
                             "discrete_toi_normal",
                "detection_note": "overlaps found once per step on the drifted positions; "
                                  "discrete_toi_normal backs the pair up along its relative "
                                  "path to the touching pose for the normal (velocities as "
                                  "with continuous detection; positions by projection)",
                "solver_iterations": MAX_PASSES,
                "contact_normal": normal,
                "contact_slop": f"gap <= {CONTACT_SLOP:g} (r_a + r_b) counts as touching",
                "ccd": "none: discrete detection after the drift (a sphere moving more than "
                       "about 2 r per step can tunnel)",
                "projection": "one pass: overlapping pairs pushed apart along the centre line, "
                              "depth split by inverse mass; spheres out of walls; velocities "
                              "untouched",
                "broad_phase": f"uniform grid over the bounding box, cell >= 2 r_max (enlarged "
                               f"to fit {CELLS_PER_SPHERE} N + 64 cells), counting sort, 27 "
                               f"neighbour cells",
                "contact_capacity": self.nd["contact_a"].shape[0],
                "wall_impulse": "accumulated impulse walls gave the spheres (observe()['wall_"
                                "impulse'])",
                "determinism": "bit-reproducible: every loop runs serially inside the "
                               "serialised time loop (no atomics race, no parallel sums)"}


class FluidSim(_KernelSim):
    """2D weakly compressible SPH (feature "fluid"): refsim's model (`refsim.models.sph`:
    Wendland C2, Tait gamma 7, Monaghan viscosity, delta-SPH density diffusion, Adami 2012 wall
    particles, negative pressures clamped to 0 or kept) and refsim's kick-drift-kick step
    with the trapezoid density drift,
    as taichi kernels (`_define_sph`). Particles, masses and initial densities are built by
    the in-house engine's own functions (`adapters.refsim_sph`), so both engines start from
    the same bits."""

    system = "sph"

    def __init__(self, scene, dt, integrator, variant):
        from .refsim_sph import WALL_LAYERS, fluid_particles, wall_particles
        ti = _runtime()["ti"]
        fluid = self.fluid = scene.fluid
        self.gravity = (np.asarray(scene.gravity, float)[:2] if scene.dim == 2
                        else np.asarray(scene.gravity, float)[[0, 2]])
        x = fluid_particles(fluid)
        walls = wall_particles(fluid)
        depth = fluid.upper[1] - x[:, 1]  # hydrostatic start, as adapters.refsim_sph.FluidSim
        rho = tait_density(fluid.density * abs(self.gravity[1]) * depth, fluid.density,
                           fluid.sound_speed)
        self.n_fluid, self.n_wall, self.wall_layers = len(x), len(walls), WALL_LAYERS
        total = self.n_fluid + self.n_wall
        self.mass = fluid.density * fluid.spacing ** 2
        self.h = fluid.smoothing * fluid.spacing
        self.cells = SPH_CELLS_PER_PARTICLE * total + 64
        arrays = {"rho": np.concatenate([rho, np.full(self.n_wall, fluid.density)]),
                  "p": np.zeros(total), "drho": np.zeros(self.n_fluid),
                  "diffused": np.zeros(self.n_fluid),
                  "acc": np.zeros((self.n_fluid, 2)),
                  "cell_count": np.zeros(self.cells, np.int32),
                  "cell_start": np.zeros(self.cells, np.int32),
                  "cell_of": np.zeros(total, np.int32), "order": np.zeros(total, np.int32),
                  "grid": np.zeros(3), "dims": np.zeros(2, np.int32),
                  "stats": np.zeros(len(SPH_STATS), np.int64)}
        lib = _RUNTIME["lib"]
        self.nd = {key: _ndarray(ti, arr) for key, arr in arrays.items()}
        self.x = _ndarray(ti, np.concatenate([x, walls]))
        self.v = _ndarray(ti, np.zeros((total, 2)))
        pack = lib["sph_t"](n_fluid=self.n_fluid, no_slip=int(fluid.no_slip),
                            tension=int(fluid.tension), mass=self.mass, h=self.h,
                            rho0=fluid.density, c0=fluid.sound_speed,
                            alpha=fluid.viscosity_alpha, delta=fluid.delta,
                            gravity=lib["vec2"](*self.gravity),
                            cell_min=self.cell_min(self.h), **self.nd)
        super().__init__(dt, integrator, variant, (self.x, self.v, pack))
        if variant == "parallel":
            self._compile_parallel(lib)

    def _compile_parallel(self, lib):
        """The `parallel` variant: one launch per step of a kernel whose stages are top-level
        (multi-threaded) loops. Its first launch compiles; it is made here with dt = 0, a
        no-op on the state (v, x, rho unchanged; a and the grid recomputed from the same
        state by the same functions, so the same bits), and timed into compile_s."""
        ti = _RUNTIME["ti"]
        step_kernel = lib["step_sph_parallel"]
        key = ("sph", "parallel")
        t0 = time.perf_counter()
        step_kernel(*self.args, 0.0)
        ti.sync()
        self.compile_s += time.perf_counter() - t0
        self.cold = self.cold or key not in _RUNTIME["compiled"]
        _RUNTIME["compiled"].add(key)
        self.nd["stats"].from_numpy(np.zeros(len(SPH_STATS), np.int64))
        self.advance = lib["advance_sph_parallel"]

    def _thread_settings(self, base) -> dict:
        if self.variant != "parallel":
            return {"threads_used": 1,
                    "threads_note": "taichi parallelises only a kernel's outermost loop; here "
                                    "it is the serialised time loop, so the SPH kernel uses "
                                    "one thread whatever cpu_max_num_threads is"}
        return {"threads_used": base["cpu_max_num_threads"],
                "time_loop": "one launch per step from Python; each stage a top-level loop "
                             "run on cpu_max_num_threads threads (counting sort serial)",
                "per_step_python_call": "one kernel launch per step (part of step_s)",
                "threads_note": "stages gather per particle (no atomics), so results are "
                                "bit-identical to the serial kernel at any thread count; "
                                "the process pins cpu_max_num_threads at ti.init "
                                f"(THREADS = {THREADS} in this adapter)"}

    @staticmethod
    def cell_min(h) -> float:
        """Grid cell: the kernel support 2h, widened by 1e-12 so that the rounding of
        (x - lo) / c never puts a pair closer than 2h two cells apart."""
        return 2.0 * h * (1.0 + 1e-12)

    def step(self, n):
        super().step(n)
        stats = self.sph_stats()
        if stats["steps_without_grid"]:
            self.failure = f"non-finite particle positions by t={self.t:.6g}"

    def sph_stats(self) -> dict:
        return dict(zip(SPH_STATS, (int(c) for c in self.nd["stats"].to_numpy())))

    def observe(self):
        n = self.n_fluid
        return {"t": self.t, "x": self.x.to_numpy()[:n].copy(),
                "v": self.v.to_numpy()[:n].copy(), "rho": self.nd["rho"].to_numpy()[:n].copy(),
                "mass": np.full(n, self.mass)}

    def settings(self):
        f = self.fluid
        base = self.base_settings()
        integ = {"name": "velocity_verlet", "order": 2,
                 "family": "kick-drift-kick (leapfrog) with continuity density",
                 "explicit": True, "symplectic": False,
                 "native": "kernel advance_sph: v += h/2 a(x, rho); D0 = D(x, v); "
                           "Dd = D_delta(x, rho); x += h v; rho += h/2 (D0 + D(x', v)) + h Dd; "
                           "v += h/2 a(x', rho')"}
        return {**base, "integrator": integ,
                "model": "WCSPH: Wendland C2, Tait gamma 7, Monaghan viscosity, delta-SPH "
                         "density diffusion, Adami walls",
                "model_source": "refsim.models.sph (same expressions, same operation order)",
                "delta_sph": f.delta,
                "pressure": "Tait, negative kept (tension)" if f.tension else
                "Tait, clamped at 0",
                "smoothing_h": self.h, "h_over_dx": f.smoothing, "sound_speed": f.sound_speed,
                "viscosity_alpha": f.viscosity_alpha, "rho0": f.density,
                "walls": "no-slip (viscosity on wall pairs)" if f.no_slip else
                "free-slip (pressure only)",
                "gravity_2d": self.gravity.tolist(),
                "particles": self.n_fluid, "wall_particles": self.n_wall,
                "wall_layers": self.wall_layers,
                "initial_conditions": "adapters.refsim_sph fluid_particles / wall_particles, "
                                      "hydrostatic Tait density (identical to refsim's)",
                "neighbours": "uniform grid over the bounding box, cell 2h (enlarged to fit "
                              f"{SPH_CELLS_PER_PARTICLE} N + 64 cells), serial counting sort, "
                              "every step; 3 x 3 cells gathered per particle",
                "pair_sums": "gathered by each particle over its own neighbours (no atomics, "
                             "no scatter): fluid-fluid and fluid-wall, wall-wall never",
                "determinism": "bit-reproducible: each sum gathered by its particle in a "
                               "fixed order (no atomics), counting sort serial; differs from "
                               "refsim's numpy engine in summation order only",
                **self._thread_settings(base),
                "stages": ["gravity", "neighbours", "sph_rates", "walls_adami",
                           "integrate:kick-drift-kick"]}


SPH_STATS = ("steps_without_grid", "steps")


STATS = ("dropped_contacts", "steps_without_grid", "max_passes", "steps_at_pass_cap",
         "impulses", "contacts", "steps")


def _ndarray(ti, arr):
    """A taichi ndarray holding `arr`: (n, 3) / (n, 2) float64 as vec3 / vec2, else by dtype."""
    arr = np.ascontiguousarray(arr)
    if arr.ndim == 2:
        out = ti.ndarray(_RUNTIME["lib"][f"vec{arr.shape[1]}"], arr.shape[0])
    else:
        dtype = {np.dtype(np.int32): ti.i32, np.dtype(np.int64): ti.i64}.get(arr.dtype, ti.f64)
        out = ti.ndarray(dtype, arr.shape[0])
    out.from_numpy(arr)
    return out
