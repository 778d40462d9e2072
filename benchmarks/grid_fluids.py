"""`refsim bench grid_fluids`: the MAC fluid step at scale, in-house and taichi side by side in
one run (issue 27's Speed).
1. One pressure projection to 1e-10 relative residual (the true residual, every solver) of the
   projection case's manufactured field (walls, u_df + G phi) at 256^2 and 512^2 cells
   (1024^2 in the full run): every formulation of both engines (refsim: direct SuperLU, cg,
   pyamg, and its multigrid where this checkout has it; taichi: direct LDLT and mgpcg), one
   `Sim.step` = one projection. Columns: `setup+solve` (a fresh Sim: build and the first projection,
   with the factorisation or hierarchy that a time-stepping run builds once) and `solve`
   (the next projection on the same Sim, setup reused: what each time step pays; best of
   the repeats). Before any time is printed every projected field is checked against u_df
   within the case's bound (the solver's tolerance through lambda_min, plus round-off), so
   all engines hold the same field. Goals: the fastest in-house solve at least 1/3 of
   taichi's throughput (cells/s) at every size; the multigrid's solve cost exponent in cells
   (log time / log cells, smallest to largest grid) at most 1.2 (refsim's "multigrid" where
   offered, else pyamg, named in the table).
2. One semi-Lagrangian advection of the face velocities (advection.advect_faces against the
   taichi group's pad + advect kernels), a periodic Taylor-Green field at CFL 0.5, schemes
   sl_linear:rk2 and sl_cubic:rk3, at 256^2 and 512^2: the two fields checked bit for bit
   (the kernels do refsim's operations in its order) before the times; best of the repeats
   after a warm-up; cells/s and the in-house/taichi ratio (goal >= 1/3).
Threads: numpy/scipy 1 (the run's BLAS setting), taichi its cpu_max_num_threads (1).
`--quick`: projection at 256^2 and 512^2, one timing each; advection at 256^2. `main` returns
the figures for the store. Unpreconditioned CG only at the smallest grid (its iterations grow
as n: minutes at 1024^2).
"""
from __future__ import annotations

import math
import time

import numpy as np

GOALS = {"ratio": 1.0 / 3.0, "exponent": 1.2}
SLOW_SOLVERS = {"cg"}  # run at the smallest grid only


def _engine(name):
    from refsim.registry import get_engine
    engine = get_engine(name)
    return engine if engine.available() else None


def _figure(name, value, units, engine, description):
    return {"figure": name, "value": float(value), "units": units, "engine": engine,
            "description": description}


# -- 1. projection -----------------------------------------------------------------------------
def projection_rows(sizes, repeats):
    """[{engine, formulation, n, first_s, solve_s, iterations, residual, error, bound}]."""
    from refsim_cases.grid_fluids.projection import CASE
    rows = []
    for n in sizes:
        p = CASE.validate({"n": n, "sides": "wall", "rtol": 1e-10})
        scene = CASE.scene(p)
        bound = CASE.tolerance(p, "steady", 0, 1.0)[0]
        reference = CASE.divergence_free(p)
        for name in ("refsim", "taichi"):
            engine = _engine(name)
            if engine is None or engine.supports(scene, "steady"):
                continue
            for form in engine.formulations(scene):
                if form in SLOW_SOLVERS and n != min(sizes):
                    continue
                row = _projection_row(engine, scene, form, n, repeats, reference, bound)
                if row is not None:
                    rows.append(row)
    return rows


def _projection_row(engine, scene, form, n, repeats, reference, bound):
    t0 = time.perf_counter()
    try:
        sim = engine.build(scene, 1.0, "steady", form)
        sim.step(1)
    except ValueError as exc:  # a solver that does not take this grid says why
        print(f"   {engine.name} {form} at {n}^2: not run ({exc})")
        return None
    first = time.perf_counter() - t0
    obs = sim.observe()
    got = np.concatenate([obs["grid.u"].ravel(), obs["grid.v"].ravel()])
    want = np.concatenate([a.ravel() for a in reference])
    error = float(np.sqrt(np.mean((got - want) ** 2)))
    if not error <= bound:
        raise AssertionError(f"{engine.name} {form} at {n}^2: the projected field is "
                             f"{error:.3g} (RMS) from u_df, above the bound {bound:.3g}")
    times = []
    for _ in range(repeats if first < 5.0 else 1):
        t0 = time.perf_counter()
        sim.step(1)
        times.append(time.perf_counter() - t0)
    sim.close()
    return {"engine": engine.name, "formulation": form, "n": n, "first_s": first,
            "solve_s": min(times), "iterations": int(obs["iterations"]),
            "residual": float(obs["residual"]), "error": error, "bound": bound}


def print_projection(rows):
    print("1. Projection to relative residual 1e-10, walls, the projection case's field "
          "(fields checked: RMS from u_df <= the case's bound, every row)")
    print(f"   {'solver':>17s} {'N':>7s} {'setup+solve s':>14s} {'solve s':>9s} "
          f"{'cells/s':>10s} {'its':>4s} {'residual':>9s} {'RMS/bound':>9s}")
    for r in sorted(rows, key=lambda r: (r["engine"], r["formulation"], r["n"])):
        print(f"   {r['engine'] + ' ' + r['formulation']:>17s} {r['n']:5d}^2 "
              f"{r['first_s']:14.3f} {r['solve_s']:9.3f} {r['n'] ** 2 / r['solve_s']:10.3e} "
              f"{r['iterations']:4d} {r['residual']:9.2e} {r['error'] / r['bound']:9.2e}")
    figures = [_figure(f"projection_{r['engine']}_{r['formulation']}_{r['n']}", r["solve_s"],
                       "s", r["engine"], f"{r['formulation']} projection at {r['n']}^2 "
                       f"(setup reused), {r['iterations']} iterations") for r in rows]
    return figures + _projection_goals(rows)


def _projection_goals(rows):
    figures = []
    forms = {r["formulation"] for r in rows if r["engine"] == "refsim"}
    mg = "multigrid" if "multigrid" in forms else "pyamg"
    mine = sorted((r for r in rows if r["engine"] == "refsim" and r["formulation"] == mg),
                  key=lambda r: r["n"])
    if len(mine) > 1:
        exponent = math.log(mine[-1]["solve_s"] / mine[0]["solve_s"]) / \
            math.log(mine[-1]["n"] ** 2 / mine[0]["n"] ** 2)
        met = "MET" if exponent <= GOALS["exponent"] else "NOT MET"
        print(f"   goal: refsim {mg} solve cost exponent in cells {mine[0]['n']}^2 -> "
              f"{mine[-1]['n']}^2: {exponent:.3f} <= {GOALS['exponent']} -> {met}")
        figures.append(_figure(f"projection_exponent_refsim_{mg}", exponent, "1", "refsim",
                               f"{mg}: log solve time / log cells"))
    theirs = sorted((r for r in rows if (r["engine"], r["formulation"]) == ("taichi", "mgpcg")),
                    key=lambda r: r["n"])
    if len(theirs) > 1:  # for comparison, no goal
        exponent = math.log(theirs[-1]["solve_s"] / theirs[0]["solve_s"]) / \
            math.log(theirs[-1]["n"] ** 2 / theirs[0]["n"] ** 2)
        print(f"   taichi mgpcg solve cost exponent in cells: {exponent:.3f}")
        figures.append(_figure("projection_exponent_taichi_mgpcg", exponent, "1", "taichi",
                               "mgpcg: log solve time / log cells"))
    for n in sorted({r["n"] for r in rows}):
        pair = {r["engine"]: r for r in rows if r["n"] == n and
                (r["engine"], r["formulation"]) in {("refsim", "multigrid"), ("taichi", "mgpcg")}}
        if len(pair) == 2:  # the same algorithm on both sides (MGPCG, V(2,2), RBGS)
            like = pair["taichi"]["solve_s"] / pair["refsim"]["solve_s"]
            print(f"   like for like at {n}^2: refsim multigrid / taichi mgpcg throughput "
                  f"{like:.2f}")
            figures.append(_figure(f"projection_mg_ratio_{n}", like, "1", "refsim/taichi",
                                   f"MGPCG cells/s, refsim multigrid over taichi mgpcg, "
                                   f"{n}^2"))
        own = [r for r in rows if r["n"] == n and r["engine"] == "refsim"]
        tai = [r for r in rows if r["n"] == n and r["engine"] == "taichi"]
        if not own or not tai:
            continue
        best, theirs = min(own, key=lambda r: r["solve_s"]), min(tai, key=lambda r: r["solve_s"])
        ratio = theirs["solve_s"] / best["solve_s"]
        met = "MET" if ratio >= GOALS["ratio"] else "NOT MET"
        print(f"   goal at {n}^2: in-house ({best['formulation']}) / taichi "
              f"({theirs['formulation']}) throughput {ratio:.2f} >= 1/3 -> {met}")
        figures.append(_figure(f"projection_ratio_{n}", ratio, "1", "refsim/taichi",
                               f"projection cells/s, refsim {best['formulation']} over taichi "
                               f"{theirs['formulation']}, {n}^2"))
    return figures


# -- 2. advection ------------------------------------------------------------------------------
def taylor_green_part(n):
    from refsim.models.grid_fluid.mac import MacGrid
    from refsim.scene import FluidGrid
    h = 2 * np.pi / n
    grid = MacGrid(n, n, h, (True, True))
    pu, pv = grid.u_points(), grid.v_points()
    u = np.sin(pu[..., 0]) * np.cos(pu[..., 1])
    v = -np.cos(pv[..., 0]) * np.sin(pv[..., 1])
    u[-1], v[:, -1] = u[0], v[:, 0]
    return FluidGrid(n, n, h, u, v, sides="periodic"), grid


def advection_rows(sizes, repeats):
    """[{scheme, n, refsim_s, taichi_s}] for one advection of u and v."""
    from refsim.integrators.semi_lagrangian import parse_scheme
    from refsim.models.grid_fluid.advection import advect_faces
    from refsim_benchmarks.inhouse import best_time
    if _engine("taichi") is None:
        return []
    from refsim_adapters.taichi_engine.groups.grid_fluids import FluidState
    rows = []
    for n in sizes:
        part, grid = taylor_green_part(n)
        dt = 0.5 * part.h
        for scheme in ("sl_linear:rk2", "sl_cubic:rk3"):
            interp, back = parse_scheme(scheme)
            state = FluidState(part, scheme, (0.0, 0.0), dt)
            got, want = state.advect(), advect_faces(part.u, part.v, grid, dt, interp, back)
            if not all(np.array_equal(a, b) for a, b in zip(got, want)):
                raise AssertionError(f"advection {scheme} at {n}^2: taichi's fields differ "
                                     "from refsim's (the same operations: bit for bit)")
            own = best_time(lambda: advect_faces(part.u, part.v, grid, dt, interp, back),
                            repeats)
            theirs = best_time(state.advect, repeats)
            rows.append({"scheme": scheme, "n": n, "refsim_s": own, "taichi_s": theirs})
    return rows


def print_advection(rows):
    print("2. One semi-Lagrangian advection of u and v, periodic Taylor-Green, CFL 0.5 "
          "(fields checked bit for bit)")
    print(f"   {'scheme':>14s} {'N':>7s} {'refsim ms':>10s} {'taichi ms':>10s} "
          f"{'refsim cells/s':>15s} {'in-house/taichi':>16s}")
    figures = []
    for r in rows:
        ratio = r["taichi_s"] / r["refsim_s"]
        met = "MET" if ratio >= GOALS["ratio"] else "NOT MET"
        print(f"   {r['scheme']:>14s} {r['n']:5d}^2 {r['refsim_s'] * 1e3:10.2f} "
              f"{r['taichi_s'] * 1e3:10.2f} {r['n'] ** 2 / r['refsim_s']:15.3e} "
              f"{ratio:16.3f}  goal >= 1/3: {met}")
        figures += [_figure(f"advection_ratio_{r['scheme']}_{r['n']}", ratio, "1",
                            "refsim/taichi", f"{r['scheme']} advection cells/s, in-house "
                            f"over taichi, {r['n']}^2"),
                    _figure(f"advection_refsim_{r['scheme']}_{r['n']}", r["refsim_s"], "s",
                            "refsim", f"{r['scheme']} advection at {r['n']}^2"),
                    _figure(f"advection_taichi_{r['scheme']}_{r['n']}", r["taichi_s"], "s",
                            "taichi", f"{r['scheme']} advection at {r['n']}^2")]
    return figures


def main(quick: bool = False) -> list[dict]:
    repeats = 1 if quick else 3
    try:
        from refsim_adapters.taichi_engine.runtime import effective_config
        threads = f"cpu_max_num_threads = {effective_config()['cpu_max_num_threads']}"
    except ImportError:
        threads = "not available"
    print(f"threads: numpy/scipy 1; taichi {threads}; times: best of {repeats} after a "
          "warm-up (one timing where a projection takes over 5 s)")
    _warm_taichi()
    figures = print_projection(projection_rows((256, 512) if quick else (256, 512, 1024),
                                               repeats))
    return figures + print_advection(advection_rows((256,) if quick else (256, 512),
                                                    repeats))


def _warm_taichi():
    """Compile taichi's fluid kernels (every formulation's) before any timing."""
    engine = _engine("taichi")
    if engine is None:
        return
    from refsim.scene import FluidGrid, Scene
    n = 8  # the smallest grid the multigrid takes
    part = FluidGrid(n, n, 1.0 / n, np.zeros((n + 1, n)), np.zeros((n, n + 1)))
    scene = Scene(parts=(part,), dim=2, meta={"solve": "projection"})
    for form in engine.formulations(scene):
        engine.build(scene, 1.0, "steady", form).close()
