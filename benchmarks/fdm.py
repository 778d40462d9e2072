"""`refsim bench fdm`: finite differences at scale, in-house and taichi side by side in one run.
1. One FTCS step of the 2D heat equation on a 1024^2 (and 256^2) grid, Dirichlet sides,
   r = 0.2: cell updates per second of the engines' own Sims (refsim: u1 = (I + h D L) u0 as
   one scipy.sparse CSR product; taichi: its kernel), after a warm-up, best of 3 timings of
   `Sim.step(n)`. Goal: in-house >= 1/3 of taichi CPU at 1024^2.
2. The 2D Poisson solve L_h u = f (case poisson_manufactured) to 1e-8 relative residual at
   257^2, 513^2, 1025^2 points by every formulation of both engines: seconds (one `step`: the
   whole solve from the initial guess, on a fresh Sim after a warm-up solve, best of
   repeats; one timing where a solve takes over 5 s), iterations, residual; the cost exponent in unknowns between the smallest and the
   largest grid; goals: the fastest in-house solver within 2x of pyamg's smoothed
   aggregation, and its exponent <= 1.2.
3. Space orders (accuracy, not speed): the heat mode's error against the PDE for FTCS at
   r = 1/4 (order 2) and r = 1/6 (order 4: the truncation D h^2 (6r - 1) u_xxxx / 12
   vanishes), and the Poisson solution's against sin(pi x) sin(pi y) (order 2).
Threads: numpy/scipy 1 (the run's BLAS setting), taichi its cpu_max_num_threads. `--quick`:
256^2 FTCS, Poisson at 65^2..257^2, one timing each. `main` returns the figures for the store.
"""
from __future__ import annotations

import math
import time

import numpy as np

from refsim_benchmarks.inhouse import best_time

GOALS = {"ftcs_ratio": 1.0 / 3.0, "poisson_ratio": 2.0, "poisson_exponent": 1.2}


def _engine(name):
    from refsim.registry import get_engine
    engine = get_engine(name)
    return engine if engine.available() else None


def ftcs_rows(sizes, repeats):
    """[{engine, n, seconds_per_step, cell_updates_per_s}] for a 2D FTCS step at r = 0.2."""
    from refsim_cases.grid_evolution.heat_mode import CASE
    rows = []
    for n in sizes:
        p = CASE.validate({"dim": 2, "cells": n - 1})
        scene, dt = CASE.scene(p), CASE.dt_of(p, 0.2)
        steps = max(2, int(2e7 // n ** 2))
        for name in ("refsim", "taichi"):
            engine = _engine(name)
            if engine is None or engine.supports(scene, "explicit_euler"):
                continue
            sim = engine.build(scene, dt, "explicit_euler", "")
            sim.step(steps)  # warm-up: compilation, caches, the update matrix
            best = best_time(lambda s=sim, k=steps: s.step(k), repeats) / steps
            sim.close()
            rows.append({"engine": name, "n": n, "seconds_per_step": best,
                         "cell_updates_per_s": n * n / best})
    return rows


def print_ftcs(rows):
    print("1. FTCS step, 2D heat equation, Dirichlet, r = 0.2")
    print(f"   {'N':>6s} {'refsim ms':>10s} {'refsim cells/s':>15s} {'taichi ms':>10s} "
          f"{'taichi cells/s':>15s} {'in-house/taichi':>16s}")
    figures = []
    for n in sorted({r["n"] for r in rows}):
        by = {r["engine"]: r for r in rows if r["n"] == n}
        own, tai = by.get("refsim"), by.get("taichi")
        line = f"   {n:4d}^2 {own['seconds_per_step'] * 1e3:10.3f} " \
               f"{own['cell_updates_per_s']:15.3e}"
        if tai is None:
            print(line + "   taichi not available (or runs no grid in this checkout)")
            continue
        ratio = own["cell_updates_per_s"] / tai["cell_updates_per_s"]
        print(line + f" {tai['seconds_per_step'] * 1e3:10.3f} {tai['cell_updates_per_s']:15.3e}"
              f" {ratio:16.3f}")
        figures.append(_figure(f"ftcs_ratio_{n}", ratio, "1", "refsim/taichi",
                               f"FTCS cell updates/s, in-house over taichi, {n}^2"))
    if figures:
        last = figures[-1]["value"]
        print(f"   goal: in-house >= {GOALS['ftcs_ratio']:.3g} of taichi at the largest grid: "
              f"{last:.3f} -> {'MET' if last >= GOALS['ftcs_ratio'] else 'NOT MET'}")
    figures += [_figure(f"ftcs_{r['engine']}_{r['n']}", r["cell_updates_per_s"],
                        "cell updates/s", r["engine"], f"FTCS step at {r['n']}^2")
                for r in rows]
    return figures


def poisson_rows(sizes, repeats):
    """[{engine, formulation, n, seconds, iterations, residual}] per solver and grid."""
    from refsim.registry import get_case
    case = get_case("poisson_manufactured")
    rows = []
    for n in sizes:
        p = case.validate({**case.variants[next(iter(case.variants))], "points": n,
                           "rtol": 1e-8, "solution": "polynomial"})
        scene = case.scene(p)
        for name in ("refsim", "taichi"):
            engine = _engine(name)
            if engine is None or engine.supports(scene, "steady"):
                continue
            for form in engine.formulations(scene):
                rows.append(_poisson_row(engine, scene, form, n, repeats))
    return rows


def _poisson_row(engine, scene, form, n, repeats):
    sim = engine.build(scene, 1.0, "steady", form)
    t0 = time.perf_counter()
    sim.step(1)  # warm-up solve (compilation, imports)
    warm = time.perf_counter() - t0
    obs = sim.observe()
    sim.close()
    times = []
    for _ in range(repeats if warm < 5.0 else 1):  # a solve of seconds: one timing
        sim = engine.build(scene, 1.0, "steady", form)
        t0 = time.perf_counter()
        sim.step(1)
        times.append(time.perf_counter() - t0)
        sim.close()
    return {"engine": engine.name, "formulation": form, "n": n, "seconds": min(times),
            "iterations": int(obs["iterations"]), "residual": float(obs["residual"])}


def print_poisson(rows):
    print("2. Poisson solve, 2D, to relative residual 1e-8 (one step = the whole solve)")
    print(f"   {'solver':>18s} " + " ".join(f"{n:>6d}^2 s  its" for n in
                                             sorted({r['n'] for r in rows})))
    figures, keys = [], sorted({(r["engine"], r["formulation"]) for r in rows})
    for key in keys:
        mine = sorted((r for r in rows if (r["engine"], r["formulation"]) == key),
                      key=lambda r: r["n"])
        print(f"   {key[0] + ' ' + key[1]:>18s} " + " ".join(
            f"{r['seconds']:9.3f} {r['iterations']:4d}" for r in mine))
        if len(mine) > 1:
            exponent = math.log(mine[-1]["seconds"] / mine[0]["seconds"]) / \
                math.log(mine[-1]["n"] ** 2 / mine[0]["n"] ** 2)
            print(f"   {'':>18s} cost exponent in unknowns {exponent:.3f}, residual "
                  f"{mine[-1]['residual']:.2e}")
            figures.append(_figure(f"poisson_exponent_{key[0]}_{key[1]}", exponent, "1",
                                   key[0], f"{key[1]}: log time / log unknowns"))
        figures += [_figure(f"poisson_{key[0]}_{key[1]}_{r['n']}", r["seconds"], "s", key[0],
                            f"{key[1]} at {r['n']}^2: {r['iterations']} iterations")
                    for r in mine]
    return figures + poisson_goals(rows)


def poisson_goals(rows):
    largest = max(r["n"] for r in rows)
    top = [r for r in rows if r["n"] == largest and r["engine"] == "refsim"]
    amg = next((r for r in top if r["formulation"] == "pyamg"), None)
    own = [r for r in top if r["formulation"] != "pyamg"]
    if amg is None or not own:
        return []
    best = min(own, key=lambda r: r["seconds"])
    ratio = best["seconds"] / amg["seconds"]
    small = min((r for r in rows if r["engine"] == "refsim" and r["formulation"] ==
                 best["formulation"]), key=lambda r: r["n"])
    exponent = math.log(best["seconds"] / small["seconds"]) / \
        math.log(best["n"] ** 2 / small["n"] ** 2)
    print(f"   fastest in-house at {largest}^2: {best['formulation']} "
          f"{best['seconds']:.3f} s = {ratio:.2f} x pyamg ({amg['seconds']:.3f} s): goal <= "
          f"{GOALS['poisson_ratio']:g} -> {'MET' if ratio <= GOALS['poisson_ratio'] else 'NOT MET'}")
    print(f"   its cost exponent {exponent:.3f}: goal <= {GOALS['poisson_exponent']:g} -> "
          f"{'MET' if exponent <= GOALS['poisson_exponent'] else 'NOT MET'}")
    return [_figure("poisson_fastest_over_pyamg", ratio, "1", "refsim", best["formulation"])]


def space_orders(quick):
    """Fitted orders in h of the error against the PDE (section 3)."""
    from refsim_cases.grid_evolution.heat_mode import CASE as HEAT
    print("3. space orders (error against the PDE; fitted slope of log error over log h)")
    figures, cells = [], (8, 16, 32) if quick else (8, 16, 32, 64)
    for label, r in (("FTCS, r = 1/4", 0.25), ("FTCS, r = 1/6", 1.0 / 6)):
        errs = [_heat_continuum_error(HEAT, c, r) for c in cells]
        slope = -np.polyfit(np.log(cells), np.log(errs), 1)[0]
        print(f"   heat 1D {label:14s} cells {cells}: errors "
              f"{', '.join(f'{e:.3e}' for e in errs)} -> order {slope:.3f}")
        figures.append(_figure(f"heat_space_order_{label[-3:]}", slope, "1", "refsim", label))
    return figures


def _heat_continuum_error(case, cells, r):
    p = case.validate({"dim": 1, "cells": cells})
    dt = case.dt_of(p, r)
    steps = round(0.05 / dt)
    sim = _engine("refsim").build(case.scene(p), dt, "explicit_euler", "")
    sim.step(steps)
    g = case.grid(p)
    exact = math.exp(g.continuum_eigenvalue() * steps * dt) * g.mode()
    return float(np.max(np.abs(sim.observe()["grid.u"] - exact)))


def _figure(name, value, units, engine, description):
    return {"figure": name, "value": float(value), "units": units, "engine": engine,
            "description": description}


def main(quick: bool = False) -> list[dict]:
    repeats = 1 if quick else 3
    print(f"threads: numpy/scipy 1; taichi {_taichi_threads()}; times: best of {repeats} "
          "after a warm-up")
    figures = print_ftcs(ftcs_rows((256,) if quick else (256, 1024), repeats))
    sizes = (65, 129, 257) if quick else (257, 513, 1025)
    try:
        figures += print_poisson(poisson_rows(sizes, repeats))
    except ValueError as exc:  # the Poisson case is not installed in this checkout
        print(f"2. Poisson: not available ({exc})")
    return figures + space_orders(quick)


def _taichi_threads():
    try:
        from refsim_adapters.taichi_engine.runtime import effective_config
        return f"cpu_max_num_threads = {effective_config()['cpu_max_num_threads']}"
    except ImportError:
        return "not available"
