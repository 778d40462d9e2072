"""Kernels made from the taichi runtime (one per system and stepper, per process, kept in
`runtime()["kernels"]`), the measured cost of a launch, and the arrays handed to the kernels
(numpy arrays where Python reads or writes them, taichi ndarrays where only kernels do).
Apart from `runtime` because the kernel modules import the runtime to initialise taichi: the
runtime importing them back made a circle."""
from __future__ import annotations

import math
import time

import numpy as np

from .runtime import runtime

# what numpy (external) array arguments add to a launch from Python against taichi ndarrays
# (taichi 1.7.4, measured on free_fall's particle kernel with n = 0, best of 40 x 100 launches,
# interleaved: 9 ndarrays 138 us; x numpy 167 us; x, v numpy 168 us; all 9 numpy 209 us)
EXTERNAL_LAUNCH_COST = ("about 30 us a launch for the first numpy external array and 5 us for "
                        "each further one, against taichi ndarrays (taichi 1.7.4, measured)")


def _make_kernels(system: str, integrator: str):
    """(start, advance) for a system; start is None where no acceleration is carried."""
    if system == "spheres":  # one kernel (kick-drift + contacts), no start kernel
        from .contact_kernels import advance_spheres
        return None, advance_spheres
    if system == "sph":  # start: grid and a(x0, rho0); advance: the time loop
        from .sph_kernels import advance_sph, start_sph
        return start_sph, advance_sph
    from .particle_kernels import system_kernels
    return system_kernels(system, integrator)


def kernels(system: str, integrator: str):
    """(start, advance) kernels for a system and stepper, made once per process."""
    made = runtime()["kernels"]
    key = (system, integrator)
    if key not in made:
        made[key] = _make_kernels(system, integrator)
    return made[key]


def launch_overhead_us(advance, args) -> float:
    """Cost of one kernel launch from Python (n = 0 steps): the price of `launch_per_step`.
    Measured once per process and kernel, best of 10 rounds of 100 launches."""
    measured = runtime()["launch_us"]
    if advance not in measured:
        best = math.inf
        for _ in range(10):
            t0 = time.perf_counter()
            for _ in range(100):
                advance(*args, 0)
            best = min(best, (time.perf_counter() - t0) / 100)
        measured[advance] = best * 1e6
    return measured[advance]


def to_ndarray(arr) -> np.ndarray:
    """An array the kernels share with Python (state observed, counters read): a C-contiguous
    numpy copy of `arr`, int32 / int64 kept, anything else float64 ((n, 2) / (n, 3) / (n, 4)
    rows are the kernels' vec2 / vec3 / vec4 elements). The runtime is arch=ti.cpu, so taichi
    hands a kernel the array's own memory (an external array: zero-copy, written in place),
    and reading it costs a numpy copy (`observed`) instead of a taichi ndarray's to_numpy
    kernel (110-250 us a call)."""
    arr = np.asarray(arr)
    dtype = arr.dtype if arr.dtype in (np.dtype(np.int32), np.dtype(np.int64)) else np.float64
    return np.array(arr, dtype=dtype, order="C", copy=True)


def to_taichi(arr, dtype=None):
    """An array only the kernels touch (parameters, scratch): a taichi ndarray holding `arr`,
    cheaper to launch with than a numpy array (EXTERNAL_LAUNCH_COST). Element type `dtype`,
    else (n, 3) / (n, 2) float64 as vec3 / vec2 and 1-D arrays by dtype (int32, int64, f64)."""
    from . import kernel_types as kt
    ti = kt.ti
    arr = np.ascontiguousarray(arr)
    if dtype is None and arr.ndim == 2:
        dtype = {2: kt.vec2, 3: kt.vec3}[arr.shape[1]]
    elif dtype is None:
        dtype = {np.dtype(np.int32): ti.i32, np.dtype(np.int64): ti.i64}.get(arr.dtype, ti.f64)
    out = ti.ndarray(dtype, arr.shape[0])
    out.from_numpy(arr)
    return out


def observed(arr: np.ndarray) -> np.ndarray:
    """A copy of a kernel's numpy array, for `Sim.observe` (the kernels write it in place)."""
    return arr.copy()


def arrays_setting(*names) -> str:
    """What a Sim's settings say of its arrays: `names` (those Python reads) are numpy."""
    return (f"{', '.join(names)}: numpy arrays handed to the kernels as external arrays "
            "(arch=ti.cpu: zero-copy, written in place; observe() copies them); parameters and "
            "kernel-only scratch: taichi ndarrays, cheaper to launch with: "
            f"{EXTERNAL_LAUNCH_COST}")
