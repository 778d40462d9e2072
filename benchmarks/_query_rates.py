"""Query throughput of every engine on a query case's batch (issue 28's Speed): the items of
`refsim bench collision` that time box-box and polygon-polygon batches side by side.

For each engine and formulation that answers the case's scene: a fresh Sim is built (its
setup timed apart: shapes, bodies, a BVH), its batch answered once untimed (warm-up: lazy
imports, caches) and checked against the case's exact answers with the case's own measures,
then answered `repeats` more times; the best time gives queries per second. The engines answer
through the same adapters the case matrix runs (pymunk, pybullet and MuJoCo one query per
call from Python: their real cost in that use; refsim one vectorised call per batch), so a
rate is printed beside the accuracy it was bought with.
"""
from __future__ import annotations

import time


def _engines(names):
    from refsim.registry import get_engine
    out = []
    for name in names:
        engine = get_engine(name)
        if engine.available():
            out.append(engine)
    return out


def rate_rows(case_name, variants, engine_names, repeats=3) -> list[dict]:
    """[{case, variant, engine, formulation, queries, setup_s, batch_s, per_s, <measures>,
    consistent}] for every engine x formulation answering the case's variants."""
    from refsim.registry import get_case
    case = get_case(case_name)
    rows = []
    for variant in variants:
        p = case.variant_params(variant)
        scene = case.scene(p)
        exact = case.exact_cached(p)
        for engine in _engines(engine_names):
            if engine.supports(scene, "query") is not None:
                continue
            for form in engine.formulations(scene):
                rows.append(_one(case, p, variant, scene, exact, engine, form, repeats))
    return rows


def _one(case, p, variant, scene, exact, engine, form, repeats) -> dict:
    t0 = time.perf_counter()
    sim = engine.build(scene, 1.0, "query", form)
    setup = time.perf_counter() - t0
    sim.step(1)  # warm-up, and the answers checked below
    obs = sim.observe()
    answered = {name: obs[f"query.{name}"] for name in case.answers}
    measured = case.measure(p, answered, exact)
    settings = sim.settings()
    bounds = case.bounds(p, settings)
    best = float("inf")
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        sim.step(1)
        best = min(best, time.perf_counter() - t0)
    sim.close()
    queries = case.batch(p)
    return {"case": case.name, "variant": variant, "engine": engine.name, "formulation": form,
            "queries": queries, "setup_s": setup, "batch_s": best, "per_s": queries / best,
            **measured,
            "consistent": all(measured[k] <= b for k, (b, _) in bounds.items())}


def print_rates(rows) -> None:
    if not rows:
        print("  (no engine answers these queries here)")
        return
    measures = [k for k in rows[0] if k not in ("case", "variant", "engine", "formulation",
                                                "queries", "setup_s", "batch_s", "per_s",
                                                "consistent")]
    head = f"  {'case/variant':28} {'engine':18} {'queries':>8} {'setup s':>9} " \
           f"{'batch s':>9} {'queries/s':>10}  " + " ".join(f"{m[:14]:>14}" for m in measures)
    print(head)
    for r in rows:
        eng = r["engine"] + (f":{r['formulation']}" if r["formulation"] else "")
        print(f"  {r['case'] + '/' + r['variant']:28} {eng:18} {r['queries']:>8d} "
              f"{r['setup_s']:9.3g} {r['batch_s']:9.3g} {r['per_s']:10.3g}  "
              + " ".join(f"{r[m]:14.3g}" for m in measures)
              + ("" if r["consistent"] else "  (beyond the case's bounds)"))
