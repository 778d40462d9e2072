"""The taichi runtime: imported and initialised once per process, lazily (the kernels made from
it and the arrays handed to them: `kernel_store`, which imports this module, never the reverse).

docs/engine_notes.md#taichi facts applied here (taichi 1.7.4), all reported in
`Sim.settings()`:
- on import taichi writes to ~/.cache/taichi and tries a network version check:
  TI_SKIP_VERSION_CHECK=ON is set before the import and the offline kernel cache is pointed at
  a temp directory (and left off: `compile_s` is then always a cold JIT, comparable run to run);
- `default_fp` is f32 (5e-5 error on free fall): ti.init(default_fp=ti.f64), and every kernel
  argument and array is declared f64;
- taichi uses every core by default: cpu_max_num_threads = 1 (a serial loop uses one anyway).
`fast_math` (default True) is turned off so LLVM may not reassociate float64 arithmetic.
`ti.init` runs once per process, lazily in the first `build` (a second ti.init would reset the
runtime and every kernel and array made before it); the kernel modules (`*_kernels`,
`*_physics`, `kernel_types`) initialise it when first imported, so nothing taichi-typed exists
before it. TI_ENABLE_PYBUF=0: with a redirected sys.stdout (pytest, notebooks) taichi otherwise
wraps every kernel call to flush a print buffer, a per-launch cost these kernels (which never
print) need not pay.
"""
from __future__ import annotations

import contextlib
import io
import os
import tempfile
import time

# CPU threads taichi may use (recorded in settings); REFSIM_TAICHI_THREADS overrides the 1
THREADS = int(os.environ.get("REFSIM_TAICHI_THREADS", "1") or 1)
OFFLINE_CACHE = False
CACHE_DIR = os.path.join(tempfile.gettempdir(),
                         f"refsim-taichi-cache-{getattr(os, 'getuid', lambda: 'user')()}")

# the taichi module, ti.init facts, kernels made, kernels compiled, launch costs: one per process
_RUNTIME: dict = {}


def import_taichi():
    """Import taichi with the version check off (it writes ~/.cache/taichi and calls the
    network otherwise, docs/engine_notes.md#taichi-import-side-effects); its banner goes
    nowhere."""
    os.environ["TI_SKIP_VERSION_CHECK"] = "ON"
    os.environ["TI_ENABLE_PYBUF"] = "0"
    with contextlib.redirect_stdout(io.StringIO()):
        import taichi as ti
    return ti


def init_taichi():
    """The taichi module, ti.init done (once per process: f64, one thread, no fast math, no
    offline cache)."""
    if _RUNTIME:
        return _RUNTIME["ti"]
    ti = import_taichi()
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        ti.init(arch=ti.cpu, default_fp=ti.f64, default_ip=ti.i32, cpu_max_num_threads=THREADS,
                fast_math=False, offline_cache=OFFLINE_CACHE, offline_cache_file_path=CACHE_DIR,
                log_level="warn")
    init_s = time.perf_counter() - t0
    _RUNTIME.update(ti=ti, init_s=init_s, kernels={}, compiled=set(), launch_us={})
    return ti


def runtime() -> dict:
    """The per-process record: ti, init_s, kernels, compiled (system, stepper) keys, launch_us."""
    init_taichi()
    return _RUNTIME


def effective_config() -> dict:
    """What ti.init actually set, read back from taichi's own config."""
    ti = runtime()["ti"]
    cfg = ti.lang.impl.current_cfg()
    return {"arch": str(cfg.arch).rsplit(".", 1)[-1],
            "default_fp": str(ti.lang.impl.get_runtime().default_fp),
            "cpu_max_num_threads": int(cfg.cpu_max_num_threads),
            "fast_math": bool(cfg.fast_math), "offline_cache": bool(cfg.offline_cache),
            "offline_cache_file_path": CACHE_DIR,
            "version_check": "skipped (TI_SKIP_VERSION_CHECK=ON set before import)",
            "python_print_buffer": "off (TI_ENABLE_PYBUF=0: no flush after each launch)",
            "runtime_init_s": _RUNTIME["init_s"]}
