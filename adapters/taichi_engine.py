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

INTEGRATORS = ("symplectic_euler", "velocity_verlet", "rk4")
VARIANTS = ("", "launch_per_step")
THREADS = 1
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
    _RUNTIME.update(ti=ti, init_s=init_s, lib=_define(ti), kernels={}, compiled=set(),
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


def _kernels(system: str, integrator: str):
    """(start, advance) kernels for a system and stepper, made once per process."""
    rt = _runtime()
    key = (system, integrator)
    if key not in rt["kernels"]:
        lib = rt["lib"]
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
    capabilities = frozenset({"gravity", "springs", "joints", "drag"})
    dims = (2, 3)
    integrators = INTEGRATORS

    def available(self) -> bool:
        try:
            _import_taichi()
        except Exception:
            return False
        return True

    def variants(self, scene):
        return VARIANTS

    def supports(self, scene, integrator=None):
        reason = super().supports(scene, integrator)
        if reason:
            return reason
        if any(s.other is not None for s in scene.springs):
            return ("taichi adapter: springs between two bodies are not modelled "
                    "(only springs to fixed anchors)")
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
        if variant not in VARIANTS:
            raise ValueError(f"taichi variant must be one of {list(VARIANTS)}, got {variant!r}")
        reason = self.supports(scene, integrator)
        if reason:
            raise ValueError(reason)
        cls = HingeSim if scene.joints else ParticleSim
        return cls(scene, dt, integrator, variant)


# ---------------------------------------------------------------------------------------------
# Sims
# ---------------------------------------------------------------------------------------------
class _KernelSim(Sim):
    """Bookkeeping shared by both systems: state ndarrays, the two kernels, timing of the
    first (compiling) calls, stepping in-kernel or one launch per step."""

    system = ""

    def __init__(self, dt, integrator, variant, state, pack):
        rt = _runtime()
        ti = rt["ti"]
        self.dt, self.integrator, self.variant, self.steps = dt, integrator, variant, 0
        self.stepper = get_integrator(integrator)
        self.x, self.v, self.a = state
        self.pack = pack
        start, self.advance = _kernels(self.system, integrator)
        key = (self.system, integrator)
        self.cold = key not in rt["compiled"]
        t0 = time.perf_counter()
        start(self.x, self.v, self.a, pack)  # a0 = a(x0, v0): Verlet's carried acceleration
        self.advance(self.x, self.v, self.a, pack, dt, 0)  # compiles on first use
        ti.sync()
        self.compile_s = time.perf_counter() - t0
        rt["compiled"].add(key)
        self.launch_us = (_launch_overhead_us(self.advance, (self.x, self.v, self.a, pack, dt))
                          if variant == "launch_per_step" else None)

    def step(self, n):
        n = int(n)
        if n < 0:
            raise ValueError(f"n must be >= 0, got {n}")
        args = (self.x, self.v, self.a, self.pack, self.dt)
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
        self.x = self.v = self.a = self.pack = None


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
        super().__init__(dt, integrator, variant, state, self._pack(ti, scene))

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
        super().__init__(dt, integrator, variant, nd[:3], pack)

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
