"""`refsim bench particle_fields`: pair forces at scale, numpy and taichi side by side in one run.
- Gravity, all pairs, at N = 10^3 and 10^4 (benchmarks.nbody.all_pairs_rows; "not available"
  when that module is absent);
- Lennard-Jones with a cell list at N = 10^4 and 10^5 (2D, density 0.7, r_c = 2.5 sigma:
  benchmarks.lennard_jones).
Printed: one line per model and N with both engines' pair interactions/s and numpy / taichi;
the cost exponent in N per engine (slope of log time per evaluation against log N: 2 for all
pairs, goal <= 1.2 for the cell list); the goal lines, each saying MET or NOT MET (cell-list
exponent <= 1.2 per engine; numpy >= 1/3 of taichi at the largest N of each model); and the
threads each engine ran on (numpy: 1; taichi: its cpu_max_num_threads, and 1 for the LJ kernel,
whose loops sit inside a serialised time loop). Times are best-of-3 after a warm-up (the
machine may be shared). `--quick`: N = 10^2, 10^3 (gravity) and 10^3, 10^4 (LJ), one repeat.
`main` returns the figures (one per row and one per derived number) for the store.
"""
from __future__ import annotations

import importlib

from refsim_benchmarks.lennard_jones import cost_exponent, lj_rows

GOALS = {"exponent": 1.2, "ratio": 1.0 / 3.0}


def gravity_rows(n_values, quick):
    """The nbody helper's rows, or None when benchmarks.nbody is not in this checkout."""
    try:
        nbody = importlib.import_module("refsim_benchmarks.nbody")
    except ModuleNotFoundError as exc:
        if exc.name != "refsim_benchmarks.nbody":
            raise
        return None
    return nbody.all_pairs_rows(n_values, quick)


def _by_n(rows):
    """{n: {engine: row}}."""
    out: dict = {}
    for r in rows:
        out.setdefault(r["n"], {})[r["engine"]] = r
    return dict(sorted(out.items()))


def print_rows(title, rows):
    """One line per N: pairs, each engine's ms and pair interactions/s, numpy / taichi."""
    print(title)
    if rows is None:
        print("   not available (benchmarks.nbody is not in this checkout)")
        return
    print(f"   {'N':>7s} {'pairs':>10s} {'numpy ms':>10s} {'numpy pairs/s':>13s} "
          f"{'taichi ms':>10s} {'taichi pairs/s':>14s} {'np/ti':>6s} {'max|F_ti-F_np|':>14s}")
    for n, engines in _by_n(rows).items():
        num, tai = engines.get("numpy"), engines.get("taichi")
        line = (f"   {n:7d} {num['pairs']:10d} {num['seconds_per_eval'] * 1e3:10.3f} "
                f"{num['pair_interactions_per_s']:13.3e}")
        if tai is None:
            print(line + "   taichi not available")
            continue
        print(line + f" {tai['seconds_per_eval'] * 1e3:10.3f} "
              f"{tai['pair_interactions_per_s']:14.3e} "
              f"{num['pair_interactions_per_s'] / tai['pair_interactions_per_s']:6.3f} "
              f"{tai['max_abs_diff_vs_numpy']:14.2e}")


def summary(rows, label, goal):
    """(lines, figures): the cost exponent per engine (against `goal`, None: none), numpy /
    taichi at every N, and the goal lines (MET / NOT MET)."""
    lines, figures = [], []
    for engine in sorted({r["engine"] for r in rows}):
        slope = cost_exponent(rows, engine)
        target = f"goal <= {goal}" if goal else "all pairs: 2 expected"
        lines.append(f"   {label} {engine}: cost exponent in N {slope:.3f} ({target})")
        figures.append(_figure(f"{label}_cost_exponent", slope, "1", engine,
                               "slope of log(time per evaluation) against log N"))
        if goal:
            lines.append(f"   GOAL {label} {engine} cost exponent <= {goal}: "
                         f"{_verdict(slope <= goal)}")
    by_n = _by_n(rows)
    ratios = {n: e["numpy"]["pair_interactions_per_s"] / e["taichi"]["pair_interactions_per_s"]
              for n, e in by_n.items() if {"numpy", "taichi"} <= set(e)}
    for n, ratio in ratios.items():
        figures.append(_figure(f"{label}_numpy_over_taichi_{n}", ratio, "1", "numpy",
                               f"numpy / taichi pair interactions per second at N = {n}", n))
    largest = max(by_n)
    if largest in ratios:
        ratio = ratios[largest]
        lines.append(f"   GOAL {label} numpy >= {GOALS['ratio']:.3f} x taichi at the largest "
                     f"N = {largest}: {ratio:.3f}, {_verdict(ratio >= GOALS['ratio'])}")
        figures.append(_figure(f"{label}_numpy_over_taichi", ratio, "1", "numpy",
                               f"numpy / taichi pair interactions per second at N = {largest}"))
    else:
        lines.append(f"   GOAL {label} numpy / taichi at N = {largest}: NOT CHECKED (no taichi)")
    return lines, figures


def _verdict(met):
    return "MET" if met else "NOT MET"


def _figure(name, value, units, engine, description, n=None):
    out = {"figure": name, "value": float(value), "units": units, "engine": engine,
           "description": description}
    if n is not None:
        out["particles"] = n
    return out


def row_figures(rows, label):
    return [_figure(f"{label}_{r['n']}", r["pair_interactions_per_s"], "pair interactions/s",
                    r["engine"], f"{label}: pair interactions per second at N = {r['n']} "
                    f"({r['seconds_per_eval']:.4g} s per evaluation, max |F - F_numpy| = "
                    f"{r['max_abs_diff_vs_numpy']:.3g})", r["n"]) for r in rows]


def threads_line() -> str:
    """The threads each engine runs on, from taichi's own config where it imports."""
    try:
        from refsim_adapters.taichi_engine.runtime import effective_config
        taichi = effective_config()["cpu_max_num_threads"]
    except ImportError:
        return "threads: numpy 1; taichi not available"
    return (f"threads: numpy 1 (no BLAS call in these kernels); taichi cpu_max_num_threads = "
            f"{taichi} for gravity (REFSIM_TAICHI_THREADS), 1 for LJ (serialised time loop)")


def main(quick: bool = False) -> list[dict]:
    gravity_n = (100, 1000) if quick else (1000, 10_000)
    lj_n = (1000, 10_000) if quick else (10_000, 100_000)
    gravity = gravity_rows(gravity_n, quick)
    lj = lj_rows(lj_n, quick)
    print(threads_line() + "; times: best of " + ("1" if quick else "3") + " after a warm-up")
    print_rows("1. gravity, all pairs (3D, softening 0.01)", gravity)
    print_rows("2. Lennard-Jones, cell list (2D, density 0.7, r_c = 2.5, periodic)", lj)
    figures = row_figures(lj, "lj_cell_list")
    print("3. cost exponent in N, numpy / taichi, goals")
    for rows, label, goal in ((gravity, "gravity_all_pairs", None),
                              (lj, "lj_cell_list", GOALS["exponent"])):
        if rows:
            lines, derived = summary(rows, label, goal)
            print("\n".join(lines))
            figures += derived
    if gravity:
        figures += row_figures(gravity, "gravity_all_pairs")
    return figures
