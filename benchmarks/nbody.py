"""All-pairs gravity throughput: refsim's numpy `pair_accelerations` against taichi's float64
kernel (`refsim_adapters.taichi_engine.gravity_kernels.accelerations`), one acceleration
evaluation of n random bodies (softening 0.01). `all_pairs_rows` is called by the particle_fields bench (not
registered here).

Pair interactions per evaluation: n (n - 1), the ordered pairs (i, j) both engines evaluate
(each body sums its n - 1 partners). Time: the best of `repeats` evaluations after a warm-up
(taichi: compilation; numpy: its work arrays). numpy runs on one thread (its blocked path makes
no BLAS call); taichi's outer loop over bodies runs on `cpu_max_num_threads` threads
(adapters/taichi_engine/runtime.py THREADS: 1 unless REFSIM_TAICHI_THREADS says otherwise).
"""
from __future__ import annotations

import time

import numpy as np

from refsim.models.nbody_gravity import pair_accelerations

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
    from refsim_adapters.taichi_engine import gravity_kernels as gk
    from refsim_adapters.taichi_engine.kernel_store import to_ndarray
    from refsim_adapters.taichi_engine.runtime import runtime
    xs, a = to_ndarray(x), to_ndarray(np.zeros_like(x))
    pack = gk.gravity_t(mass=to_ndarray(masses), G=1.0, eps2=SOFTENING ** 2)
    ti = runtime()["ti"]

    def call():
        gk.accelerations(xs, a, pack)
        ti.sync()
        return a
    return call


def all_pairs_rows(n_values=(1000, 10000), quick=False) -> list[dict]:
    """One row per engine ("numpy", "taichi") and n: best of a few evaluations after a
    warm-up; taichi rows only where taichi imports."""
    repeats = 1 if quick else 3
    rows = []
    for n in n_values:
        x, masses = _cloud(int(n))
        s_np, a_np = _best(lambda x=x, m=masses: pair_accelerations(x, m, 1.0, SOFTENING),
                           repeats)
        rows.append(_row("numpy", n, s_np, 0.0))
        try:
            call = _taichi_accel(x, masses)
        except ImportError:
            continue
        s_ti, a_ti = _best(call, repeats)
        diff = float(np.max(np.abs(np.asarray(a_ti) - a_np)))  # a numpy array on the CPU
        rows.append(_row("taichi", n, s_ti, diff))
    return rows


def _row(engine, n, seconds, diff):
    return {"model": "gravity, all pairs", "engine": engine, "n": int(n),
            "pairs": int(n) * (int(n) - 1), "seconds_per_eval": seconds,
            "pair_interactions_per_s": n * (n - 1) / seconds, "max_abs_diff_vs_numpy": diff}
