"""`refsim bench cloth`: one Baraff-Witkin step of an n x n cloth, in-house and taichi side by
side in one run (issue 16).

The cloth: n x n nodes on a 1 m square in the x-z plane, structural + shear stretch springs
(k = 100 N/m, damping 0.01 N s/m, rest lengths the initial ones), 1 kg in all, the two top
corners pinned, gravity, air drag 0.01 N s/m, h = 1/240 s, from rest (the first step of a
drop). One step, (M - h D - h^2 K) dv = h (f + h K v), timed in two parts:
- assembly: forces and Jacobians. refsim: NetworkSystem.sparse_force_jacobians + accel, the
  matrix M - h D - h^2 K (CSR) and the right-hand side (scipy.sparse, numpy; what
  BaraffWitkin._sparse_step does before its solve); taichi: the kernel that computes f, the
  right-hand side and the spring blocks and enters the triplets into a SparseMatrixBuilder,
  then builder.build() (direct), or the kernel alone (CG: matrix-free over the blocks);
- solve: refsim spsolve (SuperLU, COLAMD ordering: scipy's default) and scipy cg (rtol 1e-10,
  atol 0); taichi SparseSolver LDLT (Eigen SimplicialLDLT, AMD; pattern analysed once,
  outside the timing, as its Sim does: factorise + solve timed) and its kernel CG (rtol 1e-10).
SuperLU's fill-in (nnz(L) + nnz(U) over nnz(A), from splu with the same ordering) is printed:
a direct solve of a 2D mesh costs more than linear in the nodes (nested-dissection bound
O(N^1.5)), which the exponent shows. Times: best of `repeats` after a warm-up (one timing at
n >= 200). Cost exponent: least-squares slope of log(time) on log(nodes) over the sizes.
Threads: numpy/scipy 1 (the run's BLAS setting), taichi its cpu_max_num_threads (1 unless
REFSIM_TAICHI_THREADS says otherwise). `--quick`: n = 30, 50, 100.
"""
from __future__ import annotations

import time

import numpy as np

GOALS = {"ratio": 2.0, "exponent": 1.3}
STIFFNESS, DAMPING, DRAG, MASS, DT = 100.0, 0.01, 0.01, 1.0, 1.0 / 240.0
CG_RTOL = 1e-10


def cloth_scene(n):
    from refsim.scene import Scene, SpringNetwork
    row, col = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    idx = row * n + col
    spacing = 1.0 / (n - 1)
    x = np.c_[spacing * col.ravel(), np.zeros(n * n), -spacing * row.ravel()]
    edges = np.vstack([np.c_[idx[:, :-1].ravel(), idx[:, 1:].ravel()],
                       np.c_[idx[:-1, :].ravel(), idx[1:, :].ravel()],
                       np.c_[idx[:-1, :-1].ravel(), idx[1:, 1:].ravel()],
                       np.c_[idx[:-1, 1:].ravel(), idx[1:, :-1].ravel()]])
    net = SpringNetwork(positions=x, masses=MASS / (n * n), edges=edges, stiffness=STIFFNESS,
                        damping=DAMPING, pinned=[0, n - 1])
    return Scene(parts=(net,), gravity=(0, 0, -9.81), linear_drag=DRAG)


def timed(fn, repeats):
    """(best seconds, last result) after one warm-up call."""
    out = fn()
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def refsim_rows(scene, n, repeats):
    """The in-house step's parts: assembly, SuperLU solve, CG solve, fill-in."""
    import scipy.sparse as sp
    from scipy.sparse.linalg import cg, splu, spsolve

    from refsim.models.spring_network import NetworkSystem
    from refsim.scene import SpringNetwork
    net = scene.part(SpringNetwork)
    system = NetworkSystem(net, scene.gravity, scene.linear_drag)
    x, v = net.positions[system.free].ravel(), net.velocities[system.free].ravel()
    m = np.repeat(system.masses, 3)

    def assemble():
        kx, kv = system.sparse_force_jacobians(0.0, x, v)
        matrix = (sp.diags(m) - DT * kv - (DT * DT) * kx).tocsr()
        return matrix, DT * (m * system.accel(0.0, x, v) + DT * (kx @ v))

    t_asm, (matrix, rhs) = timed(assemble, repeats)
    t_lu, dv_lu = timed(lambda: spsolve(matrix.tocsc(), rhs), repeats)
    iterations = []

    def conjugate_gradient():
        iterations.clear()
        dv, info = cg(matrix, rhs, rtol=CG_RTOL, atol=0.0, maxiter=10 * len(rhs),
                      callback=lambda _: iterations.append(1))
        if info != 0:
            raise RuntimeError(f"scipy cg did not converge (info {info})")
        return dv

    t_cg, dv_cg = timed(conjugate_gradient, repeats)
    lu = splu(matrix.tocsc())
    fill = (lu.L.nnz + lu.U.nnz) / matrix.nnz
    return {"engine": "refsim", "n": n, "nodes": n * n, "assembly_s": t_asm, "direct_s": t_lu,
            "cg_s": t_cg, "cg_iterations": len(iterations), "fill_in": fill,
            "dv": dv_lu, "dv_cg": dv_cg}


def taichi_rows(scene, n, repeats):
    """taichi's step parts from its own Sims (formulations "" and "cg")."""
    from refsim.registry import get_engine
    engine = get_engine("taichi")
    if not engine.available():
        return None
    direct = engine.build(scene, DT, "baraff_witkin", "").bw
    direct.solve(direct.assemble())  # analyses the pattern once, as the Sim's first step
    t_asm, matrix = timed(direct.assemble, repeats)
    t_lu, dv_lu = timed(lambda: direct.solve(matrix), repeats)
    iterative = engine.build(scene, DT, "baraff_witkin", "cg").bw
    t_asm_cg, _ = timed(iterative.assemble, repeats)
    t_cg, dv_cg = timed(lambda: iterative.solve(None), repeats)
    return {"engine": "taichi", "n": n, "nodes": n * n, "assembly_s": t_asm, "direct_s": t_lu,
            "assembly_cg_s": t_asm_cg, "cg_s": t_cg, "cg_iterations": iterative.iterations,
            "dv": dv_lu, "dv_cg": dv_cg}


def exponent(rows, key):
    nodes = np.log([r["nodes"] for r in rows])
    return float(np.polyfit(nodes, np.log([key(r) for r in rows]), 1)[0])


def _figure(name, value, units, engine, description):
    return {"figure": name, "value": float(value), "units": units, "engine": engine,
            "description": description}


def print_table(own_rows, tai_rows):
    print(f"   {'n':>4s} {'nodes':>7s} | {'refsim asm':>10s} {'SuperLU':>9s} {'fill':>5s} "
          f"{'CG':>9s} {'it':>4s} | {'taichi asm':>10s} {'LDLT':>9s} {'asm(cg)':>9s} "
          f"{'CG':>9s} {'it':>4s} | {'dv agree':>8s}")
    for own, tai in zip(own_rows, tai_rows):
        agree = np.max(np.abs(own["dv"] - tai["dv"])) / np.max(np.abs(own["dv"]))
        print(f"   {own['n']:4d} {own['nodes']:7d} | {own['assembly_s'] * 1e3:10.2f} "
              f"{own['direct_s'] * 1e3:9.2f} {own['fill_in']:5.1f} {own['cg_s'] * 1e3:9.2f} "
              f"{own['cg_iterations']:4d} | {tai['assembly_s'] * 1e3:10.2f} "
              f"{tai['direct_s'] * 1e3:9.2f} {tai['assembly_cg_s'] * 1e3:9.2f} "
              f"{tai['cg_s'] * 1e3:9.2f} {tai['cg_iterations']:4d} | {agree:8.1e}")
    print("   (ms; 'dv agree': max |dv_refsim - dv_taichi| / max |dv|, both direct)")


def step_costs():
    """name -> (refsim step time, taichi step time) of a row pair, per formulation."""
    return {"direct": (lambda o: o["assembly_s"] + o["direct_s"],
                       lambda t: t["assembly_s"] + t["direct_s"]),
            "cg": (lambda o: o["assembly_s"] + o["cg_s"],
                   lambda t: t["assembly_cg_s"] + t["cg_s"])}


def summary(own_rows, tai_rows):
    figures = []
    for form, (own_cost, tai_cost) in step_costs().items():
        for own, tai in zip(own_rows, tai_rows):
            ratio = own_cost(own) / tai_cost(tai)
            figures.append(_figure(f"bw_{form}_ratio_{own['n']}", ratio, "1", "refsim/taichi",
                                   f"BW step time ({form}), in-house over taichi, "
                                   f"{own['n']}^2 cloth"))
            figures.append(_figure(f"bw_{form}_refsim_{own['n']}", own_cost(own), "s",
                                   "refsim", f"BW step ({form}), {own['n']}^2 cloth"))
            figures.append(_figure(f"bw_{form}_taichi_{own['n']}", tai_cost(tai), "s",
                                   "taichi", f"BW step ({form}), {own['n']}^2 cloth"))
        ratio_max = own_cost(own_rows[-1]) / tai_cost(tai_rows[-1])
        e_own, e_tai = exponent(own_rows, own_cost), exponent(tai_rows, tai_cost)
        e_asm = exponent(own_rows, lambda r: r["assembly_s"])
        figures += [_figure(f"bw_{form}_exponent_refsim", e_own, "1", "refsim",
                            f"BW step ({form}) cost exponent in nodes"),
                    _figure(f"bw_{form}_exponent_taichi", e_tai, "1", "taichi",
                            f"BW step ({form}) cost exponent in nodes")]
        e_last = exponent(own_rows[-2:], own_cost)
        figures.append(_figure(f"bw_{form}_exponent_refsim_last", e_last, "1", "refsim",
                               f"BW step ({form}) cost exponent between the two largest "
                               "cloths"))
        met = ratio_max <= GOALS["ratio"] and e_own <= GOALS["exponent"]
        print(f"   {form}: in-house/taichi at {own_rows[-1]['n']}^2 = {ratio_max:.2f} "
              f"(goal <= {GOALS['ratio']:g}); exponent in nodes refsim {e_own:.2f} "
              f"(assembly alone {e_asm:.2f}; between the two largest {e_last:.2f}), taichi "
              f"{e_tai:.2f} (goal <= {GOALS['exponent']:g}) -> {'MET' if met else 'NOT MET'}")
    its = [r["cg_iterations"] for r in own_rows]
    growth = exponent(own_rows, lambda r: r["cg_iterations"])
    print(f"   CG iterations {its[0]} -> {its[-1]}: ~ nodes^{growth:.2f}. At a fixed h the "
          "matrix M - h^2 K has cond ~ 1 + h^2 k lambda_max / m with m ~ 1/nodes, so the "
          "iterations tend to ~ sqrt(nodes) and CG's step to ~ nodes^1.5 once h^2 k / m >> 1 "
          "(a nested-dissection direct solve of a 2D mesh: also nodes^1.5)")
    figures.append(_figure("cg_iterations_exponent", growth, "1", "refsim",
                           "growth of CG iterations in nodes"))
    return figures


def main(quick: bool = False) -> list[dict]:
    sizes = (30, 50, 100) if quick else (50, 100, 200, 300)
    from refsim_adapters.taichi_engine.runtime import effective_config
    print(f"threads: numpy/scipy 1; taichi cpu_max_num_threads = "
          f"{effective_config()['cpu_max_num_threads']}; times: best of repeats after a "
          "warm-up (3 below n = 200, else 1)")
    print(f"One Baraff-Witkin step of an n x n cloth (structural + shear springs, k = "
          f"{STIFFNESS:g} N/m, {MASS:g} kg, h = 1/240 s, top corners pinned)")
    own_rows, tai_rows = [], []
    for n in sizes:
        scene, repeats = cloth_scene(n), 3 if n < 200 else 1
        own_rows.append(refsim_rows(scene, n, repeats))
        tai = taichi_rows(scene, n, repeats)
        if tai is None:
            print("   taichi not available")
            return []
        tai_rows.append(tai)
    print_table(own_rows, tai_rows)
    figures = summary(own_rows, tai_rows)
    for own in own_rows:
        figures.append(_figure(f"superlu_fill_in_{own['n']}", own["fill_in"], "1", "refsim",
                               f"nnz(L + U) / nnz(A), {own['n']}^2 cloth"))
    return figures
