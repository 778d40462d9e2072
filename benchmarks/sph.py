"""`refsim bench sph` (also `refsim bench --sph`): dam-break WCSPH throughput, numpy against
taichi side by side, at about 5k, 20k and 80k fluid particles: fluid particle-steps per second
over steps 20..(20 + n) of the collapse (after the first neighbour build and taichi's
compilation). Times are single samples after that warm-up.
"""
from __future__ import annotations

import time


def sph_throughput(resolutions=(50, 100, 200), steps=(40, 30, 16)):
    """[(fluid particles, {engine label: fluid particle-steps/s})] for the dam break at a/dx
    = each resolution (2 res^2 fluid particles), refsim and every taichi fluid variant."""
    from refsim.registry import get_case, get_engine
    case = get_case("dam_break")
    out = []
    for res, n in zip(resolutions, steps):
        p = case.variant_params("res20", {"resolution": res})
        scene, dt = case.scene(p), case.reference_dt(p)
        rates = {}
        for name in ("refsim", "taichi"):
            engine = get_engine(name)
            if not engine.available():
                continue
            for variant in engine.variants(scene):
                sim = engine.build(scene, dt, "velocity_verlet", variant)
                sim.step(20)  # first neighbour build, JIT, the column starting to move
                t0 = time.perf_counter()
                sim.step(n)
                elapsed = time.perf_counter() - t0
                nfluid = sim.settings()["particles"]
                threads = sim.settings().get("threads_used", sim.settings().get("threads", 1))
                rates[f"{name}{':' + variant if variant else ''} ({threads} thr)"] = \
                    nfluid * n / elapsed
                sim.close()
        out.append((2 * res * res, rates))
    return out


def print_sph(rows) -> None:
    print("5. dam-break WCSPH throughput (fluid particle-steps/s; walls extra):")
    for nfluid, rates in rows:
        numpy_rate = rates.get("refsim (1 thr)")
        for label, rate in rates.items():
            ratio = f"  numpy / this {numpy_rate / rate:5.2f}" if numpy_rate else ""
            print(f"   {nfluid:6d} fluid  {label:36s} {rate:10.3e}{ratio}")


def main(quick: bool = False) -> int:
    print_sph(sph_throughput())
    return 0
