"""Lennard-Jones force evaluation with a cell list, numpy (refsim.models.lennard_jones, one
thread) against taichi (adapters.taichi_engine.lj_kernels: its force loop sits inside the
kernel's serialised time loop, so one CPU thread whatever cpu_max_num_threads says), as in the
lj_gas case: 2D, number density 0.7 sigma^-2, cut-off 2.5 sigma (shifted), square periodic
box, eps = sigma = m = 1. Positions: the gas case's square lattice jittered by up to 0.1 sigma
(seeded), so every particle has its liquid-like ~13 partners within the cut-off.

One evaluation = the pair search (binning, sort, neighbour passes) plus the forces; timed as
the best of `repeats` evaluations after a warm-up (taichi: after its compilation; one launch
per evaluation). Pair interactions/s = (unordered) pairs within the cut-off / seconds per
evaluation, for both engines (taichi gathers each pair from both sides, numpy once).
`lj_rows` returns one dict per engine and N, the keys of benchmarks.nbody.all_pairs_rows:
model, engine, n, pairs, seconds_per_eval, pair_interactions_per_s, max_abs_diff_vs_numpy.
"""
from __future__ import annotations

import math
import time

import numpy as np

DENSITY, CUTOFF = 0.7, 2.5


def gas_positions(n, seed=1):
    """(positions (n, 3), box side): the lattice start of the lj_gas case, jittered."""
    from refsim_cases.lennard_jones.lj_gas import lattice_start
    x, _, side = lattice_start(n, DENSITY, 1.0, seed)
    x[:, :2] += np.random.default_rng(seed).uniform(-0.1, 0.1, (n, 2))
    return x, side


def numpy_eval(x, side, repeats):
    """(seconds per evaluation, forces (n, 2), pairs within the cut-off)."""
    from refsim.models.lennard_jones import LennardJonesModel
    model = LennardJonesModel(1.0, 1.0, CUTOFF, True, (side, side))
    forces = model.forces(x[:, :2])  # warm-up
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        model.forces(x[:, :2])
        best = min(best, time.perf_counter() - t0)
    return best, forces, model.pair_count(x[:, :2])


def taichi_eval(x, side, repeats):
    """(seconds per evaluation, forces (n, 2)), or None when taichi is not installed."""
    from refsim.registry import get_engine
    engine = get_engine("taichi")
    if not engine.available():
        return None
    from refsim_adapters.taichi_engine.lj_kernels import START, advance_lj
    from refsim_adapters.taichi_engine.runtime import runtime
    from refsim.scene import Particles, Scene
    from refsim.scene.lennard_jones import LennardJones
    part = LennardJones(cutoff=CUTOFF, shift=True, box=(side, side))
    scene = Scene(parts=(Particles(mass=np.ones(len(x)), position=x), part), dim=2)
    sim = engine.build(scene, 1e-3, "explicit_euler")  # compiles; a(x) below, no step
    advance_lj(sim.x, sim.v, sim.pack, 0.0, 1, START)  # warm-up
    ti = runtime()["ti"]
    ti.sync()
    elapsed = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        advance_lj(sim.x, sim.v, sim.pack, 0.0, 1, START)  # one evaluation a(x)
        ti.sync()
        elapsed = min(elapsed, time.perf_counter() - t0)
    acc = sim.nd["acc"]  # a taichi ndarray (kernel scratch) or a numpy array
    forces = np.asarray(acc.to_numpy() if hasattr(acc, "to_numpy") else acc)[:, :2]  # m = 1
    sim.close()
    return elapsed, forces


def lj_rows(n_values=(10_000, 100_000), quick=False) -> list[dict]:
    """One row per engine and N (see the module docstring)."""
    rows = []
    for n in n_values:
        x, side = gas_positions(int(n))
        repeats = 1 if quick else 3
        seconds, forces, pairs = numpy_eval(x, side, repeats)
        rows.append({"model": "lennard_jones_cell_list_2d", "engine": "numpy", "n": int(n),
                     "pairs": pairs, "seconds_per_eval": seconds,
                     "pair_interactions_per_s": pairs / seconds, "max_abs_diff_vs_numpy": 0.0})
        measured = taichi_eval(x, side, repeats)
        if measured is not None:
            t_seconds, t_forces = measured
            rows.append({"model": "lennard_jones_cell_list_2d", "engine": "taichi",
                         "n": int(n), "pairs": pairs, "seconds_per_eval": t_seconds,
                         "pair_interactions_per_s": pairs / t_seconds,
                         "max_abs_diff_vs_numpy": float(np.max(np.abs(t_forces - forces)))})
    return rows


def cost_exponent(rows, engine) -> float:
    """Slope of log(seconds per evaluation) against log N over the engine's rows."""
    mine = [r for r in rows if r["engine"] == engine]
    if len(mine) < 2:
        return float("nan")
    n = np.log([r["n"] for r in mine])
    t = np.log([r["seconds_per_eval"] for r in mine])
    return float(np.polyfit(n, t, 1)[0])
