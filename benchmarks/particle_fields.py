"""`refsim bench particle_fields`: pair forces at scale, side by side in one run.
- Gravity, all pairs, at N = 10^3 and 10^4 (benchmarks.nbody.all_pairs_rows, written beside
  this bench; "not available" when that module is absent);
- Lennard-Jones with a cell list at N = 10^4 and 10^5 (2D, density 0.7, r_c = 2.5 sigma:
  benchmarks.lennard_jones), numpy against taichi (CPU, one thread).
Printed: pair interactions/s per engine and N, the cost exponent in N (fit of the time per
evaluation against N; goal <= 1.2 for the cell list), and numpy / taichi throughput at the
largest N (goal >= 1/3). `--quick`: N = 10^2, 10^3 (gravity) and 10^3, 10^4 (LJ).
`main` returns the figures (one per row and one per derived number) for the store.
"""
from __future__ import annotations

import importlib

from benchmarks.lennard_jones import cost_exponent, lj_rows

GOALS = {"exponent": 1.2, "ratio": 1.0 / 3.0}


def gravity_rows(n_values, quick):
    """The nbody helper's rows, or None when benchmarks.nbody is not in this checkout."""
    try:
        nbody = importlib.import_module("benchmarks.nbody")
    except ModuleNotFoundError as exc:
        if exc.name != "benchmarks.nbody":
            raise
        return None
    return nbody.all_pairs_rows(n_values, quick)


def print_rows(title, rows):
    print(title)
    if rows is None:
        print("   not available (benchmarks.nbody is not in this checkout)")
        return
    for r in rows:
        print(f"   N = {r['n']:7d}  {r['engine']:8s} {r['seconds_per_eval'] * 1e3:10.3f} ms/eval"
              f"  {r['pair_interactions_per_s']:10.3e} pairs/s  max |F - F_numpy| "
              f"{r['max_abs_diff_vs_numpy']:.2e}")


def summary(rows, label, goal):
    """(lines, figures): the cost exponent per engine (against `goal`, None: none), numpy /
    taichi at the largest N."""
    lines, figures = [], []
    for engine in sorted({r["engine"] for r in rows}):
        slope = cost_exponent(rows, engine)
        target = f"goal <= {goal}" if goal else "all pairs: 2 expected"
        lines.append(f"   {label} {engine}: cost exponent in N {slope:.3f} ({target})")
        figures.append(_figure(f"{label}_cost_exponent", slope, "1", engine,
                               "slope of log(time per evaluation) against log N"))
    largest = max(r["n"] for r in rows)
    rate = {r["engine"].split()[-1].strip("()"): r["pair_interactions_per_s"] for r in rows
            if r["n"] == largest}  # "refsim (numpy)" and "numpy" both name numpy
    if "numpy" in rate and "taichi" in rate:
        ratio = rate["numpy"] / rate["taichi"]
        lines.append(f"   {label} numpy / taichi throughput at N = {largest}: {ratio:.3f} "
                     f"(goal >= {GOALS['ratio']:.3f})")
        figures.append(_figure(f"{label}_numpy_over_taichi", ratio, "1", "numpy",
                               f"numpy / taichi pair interactions per second at N = {largest}"))
    return lines, figures


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


def main(quick: bool = False) -> list[dict]:
    gravity_n = (100, 1000) if quick else (1000, 10_000)
    lj_n = (1000, 10_000) if quick else (10_000, 100_000)
    gravity = gravity_rows(gravity_n, quick)
    print_rows("1. gravity, all pairs (3D)", gravity)
    lj = lj_rows(lj_n, quick)
    print_rows("2. Lennard-Jones, cell list (2D, density 0.7, r_c = 2.5, periodic)", lj)
    figures = row_figures(lj, "lj_cell_list")
    print("3. scaling and numpy / taichi")
    for rows, label, goal in ((gravity, "gravity_all_pairs", None),
                              (lj, "lj_cell_list", GOALS["exponent"])):
        if rows:
            lines, derived = summary(rows, label, goal)
            print("\n".join(lines))
            figures += derived
    if gravity:
        figures += row_figures(gravity, "gravity_all_pairs")
    return figures
