"""What every taichi Sim shares: the kernel arguments, the kernels, timing of the first
(compiling) calls, stepping in-kernel or one launch per step, and the settings every system
reports.

docs/engine_notes.md#taichi facts applied here (taichi 1.7.4):
- one launch per step from Python costs about 29 us (measured here: 50-90 us, growing with the
  number of array arguments) against ~0.05 us per step inside a kernel: the default runs the
  loop in the kernel; the engine variant "launch_per_step" launches once per step and records
  the launch cost it measured;
- the arrays Python reads (the observed state, counters: `host_arrays`) are numpy arrays,
  which taichi passes to a kernel as external arrays (on the CPU the kernel reads and writes
  their memory: observing is a numpy copy, ~0.3 us, where a taichi ndarray's to_numpy launches
  a kernel, 110-250 us). taichi's Python side sets up each external array argument more slowly
  than an ndarray one (kernel_store.EXTERNAL_LAUNCH_COST: ~30 us a launch for the first, ~5 us
  each further one), so parameters and kernel-only scratch stay taichi ndarrays; the measured
  launch cost contains the external arrays' share;
- the first call compiles (about 0.1 s cold) and each new template argument recompiles: build
  makes the first calls and reports their time as `compile_s`; n is a runtime i32, so no step
  recompiles anything.
"""
from __future__ import annotations

import time

from refsim.engine import Sim
from refsim.integrators import get_integrator

from .kernel_store import (
    EXTERNAL_LAUNCH_COST,
    arrays_setting,
    kernels,
    launch_overhead_us,
)
from .runtime import THREADS, effective_config, runtime

NATIVE = {"symplectic_euler": "kernel kick_drift: v += h a(x, v); x += h v",
          "velocity_verlet": "kernel velocity_verlet: v += h/2 a; x += h v; a = a(x, v); "
                             "v += h/2 a (closing half kick corrected once when a depends on v)",
          "rk4": "kernel rk4: classical 4-stage Runge-Kutta on (x, v)"}
INTEGRATORS = tuple(NATIVE)  # the steppers these kernels implement (the engine's)
I32_MAX = 2 ** 31 - 1  # steps per launch at most (n is an i32 kernel argument)


def checked_integrator(integrator: str) -> str:
    """`integrator` when it names one of INTEGRATORS exactly (the base lets "rk4:2" through:
    there is no order parameter here), else a ValueError."""
    if integrator not in INTEGRATORS:
        raise ValueError(f"taichi integrator must be one of {list(INTEGRATORS)}, "
                         f"got {integrator!r}")
    return integrator


class KernelSim(Sim):
    """A system stepped by taichi kernels. `args` are the kernel arguments before h and n
    (arrays and argpacks); subclasses set `system` (the kernels' key in runtime) and
    `host_arrays` (the arrays held as numpy, named in settings)."""

    system = ""
    host_arrays = ("x", "v")

    def __init__(self, dt, integrator, variant, args):
        rt = runtime()
        self.dt, self.integrator, self.variant, self.steps = dt, integrator, variant, 0
        self.stepper = get_integrator(integrator)
        self.args = tuple(args)
        start, self.advance = kernels(self.system, integrator)
        key = (self.system, integrator)
        self.cold = key not in rt["compiled"]
        t0 = time.perf_counter()
        if start is not None:
            start(*self.args)  # a0 = a(x0, v0): Verlet's carried acceleration
        self.advance(*self.args, dt, 0)  # compiles on first use
        rt["ti"].sync()
        self.compile_s = time.perf_counter() - t0
        rt["compiled"].add(key)
        self.launch_us = (launch_overhead_us(self.advance, (*self.args, dt))
                          if variant == "launch_per_step" else None)

    def _step_impl(self, n):
        args = (*self.args, self.dt)
        if self.variant == "launch_per_step":
            for _ in range(n):
                self.advance(*args, 1)
        else:
            done = 0
            while done < n:
                chunk = min(n - done, I32_MAX)
                self.advance(*args, chunk)
                done += chunk

    def time_after(self, n) -> float:
        """Simulated time once the n steps under way are counted (for failure messages)."""
        return (self.steps + n) * self.dt

    def base_settings(self) -> dict:
        described = self.stepper.describe()
        loop = ("one kernel launch per step from Python" if self.variant == "launch_per_step"
                else "time loop inside one kernel, ti.loop_config(serialize=True)")
        out = {"integrator": {**described, "native": NATIVE[self.integrator]},
               "dtype": "float64", "threads": THREADS, **effective_config(),
               "time_loop": loop, "arrays": arrays_setting(*self.host_arrays),
               "kernel_args": "arrays + argpack, n a runtime i32 "
               "(no recompilation per build or per step count)",
               "compile": "cold JIT in this build" if self.cold else
               "kernels already compiled in this process (launch time only)"}
        if self.launch_us is not None:
            out["per_step_python_call_us"] = self.launch_us
            out["per_step_python_call"] = (
                "one kernel launch per step: its measured cost (per_step_python_call_us; "
                "docs/engine_notes.md#taichi-kernel-launch-cost: about 29 us with taichi "
                "ndarrays) is part of step_s and includes "
                f"its {len(self.host_arrays)} numpy external arrays: {EXTERNAL_LAUNCH_COST}")
        else:
            out["per_step_python_call"] = "none (one launch per Sim.step(n) call)"
        return out

    def close(self):
        self.args = ()
