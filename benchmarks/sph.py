"""`refsim bench sph` (also `refsim bench --sph`): dam-break WCSPH throughput, numpy against
taichi side by side, at about 5k, 20k and 80k fluid particles: fluid particle-steps per second
over steps 20..(20 + n) of the collapse (after the first neighbour build and taichi's
compilation). Times are single samples after that warm-up. `main` returns the figures as
data (one dict per engine and size, refsim.store.figures) for the store.
"""
from __future__ import annotations

import time


def sph_throughput(resolutions=(50, 100, 200), steps=(40, 30, 16), figures=None):
    """[(fluid particles, {engine label: fluid particle-steps/s})] for the dam break at a/dx
    = each resolution (2 res^2 fluid particles), refsim and every taichi fluid variant; each
    measurement also appended to `figures` (a list) as a figure dict when given."""
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
                if figures is not None:
                    figures.append(throughput_figure(2 * res * res, name, variant, dt, n,
                                                     elapsed, nfluid, threads))
        out.append((2 * res * res, rates))
    return out


def print_sph(rows) -> None:
    print("5. dam-break WCSPH throughput (fluid particle-steps/s; walls extra):")
    for nfluid, rates in rows:
        numpy_rate = rates.get("refsim (1 thr)")
        for label, rate in rates.items():
            ratio = f"  numpy / this {numpy_rate / rate:5.2f}" if numpy_rate else ""
            print(f"   {nfluid:6d} fluid  {label:36s} {rate:10.3e}{ratio}")


def throughput_figure(size, engine, variant, dt, steps, elapsed, nfluid, threads) -> dict:
    return {"figure": f"wcsph_throughput_{size}", "value": nfluid * steps / elapsed,
            "units": "fluid particle-steps/s",
            "description": f"dam-break WCSPH at about {size} fluid particles (walls extra): "
                           "fluid particle-steps per second over steps 20..(20 + steps), one "
                           "sample after the first neighbour build and compilation",
            "engine": engine, "engine_variant": variant, "integrator": "velocity_verlet",
            "dt": float(dt), "steps": steps, "us_per_step": elapsed / steps * 1e6,
            "step_s": elapsed, "repeats": 1, "threads": threads, "particles": nfluid,
            "measured_on": "dam_break"}


def main(quick: bool = False) -> list[dict]:
    figures = []
    print_sph(sph_throughput(figures=figures))
    return figures
