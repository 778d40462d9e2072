"""`refsim bench collision`: collision detection at scale (issue 28's Speed), the items of
ITEMS one after the other, each printing its table and returning its figures (a new item: a
function `item(quick, repeats) -> list[figure]` appended to ITEMS).

1. BVH over spheres (`bvh_item`): the bvh_spheres case's batches (N primitive spheres, radii
   over a decade, the cube grown as N^(1/3) for 4 overlaps per query; M = 1e3 query spheres,
   10 % grazing) at N = 1e3, 1e4, 1e5, each split of refsim.models.collision.bvh ("morton":
   radix splits on the Morton order; "median": object median on each node's widest axis):
   `build` (the tree), `query` (both batched queries: every overlapping pair and each
   centre's nearest surface) and brute force beside them (the case's oracle, every M N pair
   in chunks: both answers). Before any time is printed each split's answers are measured by
   the case against the oracle: zero false negatives, zero false positives, zero nearest
   mismatches, nearest_err within its bound, else the bench stops. Cost exponents: the slope
   of log time against log N, least squares over the three sizes and over the last decade;
   goals (issue 28): build and query exponents at most 1.2 for N up to 1e5 (query: per query
   ~log N, so the batch's exponent in N far below 1; brute force ~1 for comparison).
Times: CPU time of the process (time.process_time; numpy runs all of it on one thread, so
on a quiet machine it is the wall time), best of repeats after a warm-up (the brute force: one
timing at N = 1e5). On the shared 2-core machine at a load of 4-6, two runs a minute apart
gave wall times 2-4x these CPU times; the CPU times and exponents still move with the load
(caches shared): read two runs before trusting a digit.
2. Box and polygon pairs (`pairs_item`): queries per second of every engine on the
   oriented_boxes and convex_polygons batches of 10^3 and 10^5 pairs, each engine's answers
   checked by the case before its rate (wall time: the engines' own calls are the cost).
`--quick`: the same sizes, one timing each (pairs: 10^3 only). `main` returns the figures for
the store.
"""
from __future__ import annotations

import time

import numpy as np


def best_time(fn, repeats):
    """Least CPU time of this process over `repeats` calls after a warm-up (numpy runs these
    on one thread: on a quiet machine the wall time; on a shared one, steadier)."""
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return min(times)


GOAL_EXPONENT = 1.2
BVH_SIZES = (1000, 10000, 100000)
BVH_QUERIES = 1000
LEAF_SIZE = 8  # as the refsim engine's group builds it


def _figure(name, value, units, variant, description):
    return {"figure": name, "value": float(value), "units": units, "engine": "refsim",
            "engine_variant": variant, "description": description,
            "measured_on": "bvh_spheres"}


def _check(case, p, split, tree, exact):
    """The split's answers against the oracle, by the case's own measures and bounds."""
    from refsim.models.collision.bvh import nearest, overlap_pairs
    part = case.scene(p).parts[0]
    index, distance = nearest(tree, part.query_center)
    answered = {"pairs": overlap_pairs(tree, part.query_center, part.query_radius),
                "nearest": index, "nearest_distance": distance}
    got = case.measure(p, answered, exact)
    for column, (bound, why) in case.bounds(p, {}).items():
        if not got[column] <= bound:
            raise AssertionError(f"bvh {split} at N = {p['n']}: {column} {got[column]:.3g} "
                                 f"above its bound {bound:.3g} ({why})")
    return got


def bvh_rows(quick, repeats):
    """[{n, split, build_s, query_s, brute_s, pairs, fn, fp}] over BVH_SIZES."""
    from refsim.models.collision.bvh import SPLITS, build, nearest, overlap_pairs
    from refsim.registry import get_case
    case = get_case("bvh_spheres")
    rows = []
    for n in BVH_SIZES:
        p = case.validate({**case.variant_params("default"), "n": n, "m": BVH_QUERIES})
        part = case.scene(p).parts[0]
        t0 = time.process_time()
        exact = case.exact(p)
        brute = time.process_time() - t0
        if not quick and brute < 2.0:
            brute = min(brute, best_time(lambda: case.exact(p), repeats))

        def query(tree):
            overlap_pairs(tree, part.query_center, part.query_radius)
            nearest(tree, part.query_center)

        for split in SPLITS:
            tree = build(part.prim_center, part.prim_radius, LEAF_SIZE, split)
            got = _check(case, p, split, tree, exact)
            rows.append({"n": n, "split": split, "brute_s": brute, "depth": tree.depth,
                         "build_s": best_time(lambda: build(part.prim_center, part.prim_radius,
                                                            LEAF_SIZE, split), repeats),
                         "query_s": best_time(lambda: query(tree), repeats),
                         "pairs": len(exact["sure_keys"]), "fn": got["false_negatives"],
                         "fp": got["false_positives"]})
    return rows


def exponents(ns, times) -> tuple[float, float]:
    """(least-squares slope of log t on log n over all sizes, slope over the last two)."""
    x, y = np.log(np.asarray(ns, float)), np.log(np.asarray(times, float))
    return float(np.polyfit(x, y, 1)[0]), float((y[-1] - y[-2]) / (x[-1] - x[-2]))


def print_bvh(rows):
    print(f"1. BVH over spheres, M = {BVH_QUERIES} queries (overlap pairs + nearest), leaves "
          f"<= {LEAF_SIZE}; answers checked against brute force (0 FN, 0 FP, 0 mismatches)")
    print(f"   {'split':>12s} {'N':>7s} {'depth':>5s} {'pairs':>6s} {'build ms':>9s} "
          f"{'query ms':>9s} {'queries/s':>10s} {'brute ms':>9s} {'brute/query':>11s}")
    figures = []
    for r in rows:
        print(f"   {r['split']:>12s} {r['n']:7d} {r['depth']:5d} {r['pairs']:6d} "
              f"{r['build_s'] * 1e3:9.2f} {r['query_s'] * 1e3:9.2f} "
              f"{BVH_QUERIES / r['query_s']:10.3e} {r['brute_s'] * 1e3:9.1f} "
              f"{r['brute_s'] / r['query_s']:11.1f}")
        for what in ("build", "query"):
            figures.append(_figure(f"bvh_{what}_{r['split']}_{r['n']}", r[f"{what}_s"], "s",
                                   r["split"], f"BVH {what} ({r['split']} split), N = "
                                   f"{r['n']}, M = {BVH_QUERIES}"))
    sizes = sorted({r["n"] for r in rows})
    brute = [next(r["brute_s"] for r in rows if r["n"] == n) for n in sizes]
    for n, t in zip(sizes, brute):
        figures.append(_figure(f"bvh_brute_force_{n}", t, "s", "brute_force",
                               f"brute force over all M N pairs, N = {n}, M = {BVH_QUERIES}"))
    lines = [("brute_force", "brute", brute)]
    for split in dict.fromkeys(r["split"] for r in rows):
        mine = sorted((r for r in rows if r["split"] == split), key=lambda r: r["n"])
        lines += [(split, what, [r[f"{what}_s"] for r in mine]) for what in ("build", "query")]
    for variant, what, times in lines:
        fit, last = exponents(sizes, times)
        met = "MET" if max(fit, last) <= GOAL_EXPONENT else "NOT MET"
        goal = "" if what == "brute" else f"  goal <= {GOAL_EXPONENT} (both): {met}"
        print(f"   {variant:>12s} {what} cost exponent in N {sizes[0]}..{sizes[-1]}: fit "
              f"{fit:.3f}, last decade {last:.3f}{goal}")
        figures += [_figure(f"bvh_{what}_exponent_{variant}", fit, "1", variant,
                            f"log {what} time / log N, least squares over N = {sizes}"),
                    _figure(f"bvh_{what}_exponent_last_{variant}", last, "1", variant,
                            f"log {what} time / log N over the last decade")]
    return figures


def bvh_item(quick, repeats):
    return print_bvh(bvh_rows(quick, repeats))


def pairs_item(quick, repeats):
    """2. Box-box and polygon-polygon batches of 10^3 and 10^5 pairs (the oriented_boxes and
    convex_polygons cases' default and large variants) on every engine answering them, in-house
    batch beside each engine's per-query calls (benchmarks/_query_rates.py: each answer checked
    with the case's measures and bounds before its rate is printed). `--quick`: 10^3 only."""
    from refsim_benchmarks._query_rates import print_rates, rate_rows
    variants = ["default"] if quick else ["default", "large"]
    figures = []
    for case in ("oriented_boxes", "convex_polygons"):
        rows = rate_rows(case, variants, PAIR_ENGINES, repeats)
        print(f"\n{case}: queries per second (wall time, best of {repeats} after a checked "
              "warm-up answer; setup apart)")
        print_rates(rows)
        figures += [_figure(f"{r['case']}_{r['engine']}"
                            + (f"_{r['formulation']}" if r["formulation"] else ""),
                            r["per_s"], "queries/s", r["variant"],
                            f"{r['queries']} pairs, {r['engine']} {r['formulation'] or ''}"
                            f" (distance_err {r['distance_err']:.3g} m)") for r in rows]
    return figures


PAIR_ENGINES = ("refsim", "mujoco", "pybullet", "pymunk")
ITEMS = [bvh_item, pairs_item]


def main(quick: bool = False) -> list[dict]:
    repeats = 1 if quick else 5
    print(f"threads: numpy 1; times: CPU time (process_time), best of {repeats} after a "
          "warm-up")
    figures = []
    for item in ITEMS:
        figures += item(quick, repeats)
    return figures
