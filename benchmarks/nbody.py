"""All-pairs gravity throughput: refsim's numpy `pair_accelerations` against taichi's float64
kernel (`adapters.taichi_engine.gravity_kernels.accelerations`), one acceleration evaluation of
n random bodies. `all_pairs_rows` is called by the particle_fields bench (not registered here).
"""
from __future__ import annotations

import time

import numpy as np

from refsim.models.nbody_gravity import pair_accelerations

BLOCK_ROWS = 1000  # numpy rows per block: a (1000, n, 3) temporary, 240 MB at n = 10^4
SOFTENING = 0.01


def _cloud(n, seed=14):
    rng = np.random.default_rng(seed)
    return rng.normal(size=(n, 3)), rng.uniform(0.5, 1.5, n) / n


def _best(call, repeats):
    call()  # warm-up (taichi: compilation; numpy: allocation)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = call()
        times.append(time.perf_counter() - t0)
    return min(times), out


def _taichi_accel(x, masses):
    from adapters.taichi_engine import gravity_kernels as gk
    from adapters.taichi_engine.kernel_store import to_ndarray
    from adapters.taichi_engine.runtime import runtime
    xs, a = to_ndarray(x), to_ndarray(np.zeros_like(x))
    pack = gk.gravity_t(mass=to_ndarray(masses), G=1.0, eps2=SOFTENING ** 2)
    ti = runtime()["ti"]

    def call():
        gk.accelerations(xs, a, pack)
        ti.sync()
        return a
    return call


def all_pairs_rows(n_values=(1000, 10000), quick=False) -> list[dict]:
    """One row per engine and n: best of a few evaluations after a warm-up."""
    repeats = 1 if quick else 3
    rows = []
    for n in n_values:
        x, masses = _cloud(int(n))
        block = BLOCK_ROWS if n > BLOCK_ROWS else None
        s_np, a_np = _best(lambda: pair_accelerations(x, masses, 1.0, SOFTENING, block), repeats)
        rows.append(_row("refsim (numpy)", n, s_np, 0.0))
        try:
            call = _taichi_accel(x, masses)
        except ImportError:
            continue
        s_ti, a_ti = _best(call, repeats)
        diff = float(np.max(np.abs(a_ti.to_numpy() - a_np)))
        rows.append(_row("taichi (cpu, f64)", n, s_ti, diff))
    return rows


def _row(engine, n, seconds, diff):
    return {"model": "gravity, all pairs", "engine": engine, "n": int(n),
            "seconds_per_eval": seconds, "pair_interactions_per_s": n * (n - 1) / seconds,
            "max_abs_diff_vs_numpy": diff}
