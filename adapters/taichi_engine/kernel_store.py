"""Kernels made from the taichi runtime (one per system and stepper, per process, kept in
`runtime()["kernels"]`), the measured cost of a launch, and numpy arrays as taichi ndarrays.
Apart from `runtime` because the kernel modules import the runtime to initialise taichi: the
runtime importing them back made a circle."""
from __future__ import annotations

import math
import time

import numpy as np

from .runtime import runtime


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


def to_ndarray(arr):
    """A taichi ndarray holding `arr`: (n, 3) / (n, 2) float64 as vec3 / vec2, else by dtype."""
    from . import kernel_types as kt
    ti = kt.ti
    arr = np.ascontiguousarray(arr)
    if arr.ndim == 2:
        out = ti.ndarray({2: kt.vec2, 3: kt.vec3}[arr.shape[1]], arr.shape[0])
    else:
        dtype = {np.dtype(np.int32): ti.i32, np.dtype(np.int64): ti.i64}.get(arr.dtype, ti.f64)
        out = ti.ndarray(dtype, arr.shape[0])
    out.from_numpy(arr)
    return out
