"""`refsim bench sleeping_top [--quick]`: the sleeping-top threshold I3^2 w3^2 > 4 I1' M g l
found by a sweep on every engine that runs the heavy top (`refsim_cases.rigid.heavy_top`), side by
side with the theory.

For every engine x formulation x fixed-step integrator that runs a pivoted top, at dt = 1e-2
and 2e-3 (--quick: 1e-2 only, and refsim's default formulation only), `find_threshold` bisects
the spin ratio r = w3 / w3c at which the top, released at a tilt of 1e-3 rad, keeps its tilt
below 10 times the start over 3 periods 2 pi / Omega_c, in [0.8, 1.2] to a resolution of 1e-3
(where the top stays up at 0.8 or falls at 1.2, the sweep is repeated in [0.3, 3]).

Theory. The linearised top (heavy_top's docstring) is stable iff r > 1; with this finite-time,
finite-factor criterion, bisecting the closed form `linear_tilt_ratio` at exact times gives
r_lin = 1.00504 in [1, 10 / sqrt(99) = 1.00504]: r = 1 falls (|1 - i Omega_c t| passes 10 at
Omega_c t = 10 < 6 pi), and a stable top's tilt peaks at r / sqrt(r^2 - 1) times the start,
reached within the 3 periods. The engine's check looks only every quarter radian of Omega_c,
so the bench bisects the closed form at the engine's own look times (`look_times`): r_look.

"Agrees": |r_found - r_look| <= `agreement_bound`, the sum of
  - resolution / 2: the bisection returns the midpoint of a bracket of width <= resolution
    that holds the engine's transition;
  - (factor tilt)^2 = 1e-4: the nonlinear terms, O(theta^2) relative in the modes' rates
    at tilts up to factor x tilt = 1e-2 rad, shift r by as much;
  - (W dt)^p, W = w3c (the fastest rate at r = 1, above I3 w3c / I1' and Omega_c), p the
    integrator's nominal order: a p-th order step perturbs the gyroscopic and gravity
    coefficients of the modified equation by C (W dt)^p relative, C <= 1 for every method
    here, and r_c = I3 w3 / (2 sqrt(I1' M g l)) moves by at most that relative amount;
  - 1e-6: the closed form's own bisection.
A first-order engine at dt = 1e-2 may sit off r_look by up to (W dt) = 0.077 and still agree:
the measured shift is the finding (an implicit integrator's numerical damping or growth moves
the threshold; its sign says which).
"""
from __future__ import annotations

import math
import time

import numpy as np

DTS, QUICK_DTS = (1e-2, 2e-3), (1e-2,)
ENGINES = ("refsim", "mujoco", "pybullet", "taichi", "pymunk")
WINDOW, WIDE_WINDOW = (0.8, 1.2), (0.3, 3.0)
RESOLUTION, PERIODS, FACTOR, TILT = 1e-3, 3.0, 10.0, 1e-3
LINEAR_RESOLUTION = 1e-6
UNITS = "w3 / w3c"


def base_params() -> dict:
    """The heavy top's sleeping_stable parameters at the sweep's release tilt."""
    from refsim_cases.rigid.heavy_top import CASE
    return CASE.variant_params("sleeping_stable", {"tilt": TILT})


def look_times(dt: float, p: dict | None = None) -> np.ndarray:
    """Omega_c t at find_threshold's checks: every `chunk` steps (a quarter radian of Omega_c)
    until the time passes PERIODS periods 2 pi / Omega_c, as its loop steps."""
    from refsim_cases.rigid.heavy_top import threshold_rate
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"sleeping_top dt must be a finite number > 0, got {dt}")
    rate = threshold_rate(p or base_params())
    chunk = max(1, round(0.25 / (rate * dt)))
    end = PERIODS * 2.0 * np.pi / rate
    looks = math.ceil(end / (chunk * dt) - 1e-9)
    return rate * dt * chunk * np.arange(1, looks + 1)


def exact_times(samples: int = 20001) -> np.ndarray:
    """Omega_c t densely over PERIODS periods: the closed form at (near) every time."""
    return np.linspace(0.0, 2.0 * np.pi * PERIODS, samples)


def linear_threshold(omega_c_t) -> float:
    """The spin ratio at which the linearised top's tilt, seen at times `omega_c_t`, stays
    below FACTOR times its start: the closed form bisected in WINDOW to LINEAR_RESOLUTION."""
    from refsim_cases.rigid.heavy_top import linear_tilt_ratio
    low, high = WINDOW
    while high - low > LINEAR_RESOLUTION:
        mid = 0.5 * (low + high)
        stays = linear_tilt_ratio(mid, omega_c_t).max() < FACTOR
        low, high = (low, mid) if stays else (mid, high)
    return 0.5 * (low + high)


def agreement_bound(order: float, dt: float, p: dict | None = None) -> float:
    """|r_found - r_look| allowed (module docstring): resolution / 2 + (factor tilt)^2 +
    (w3c dt)^order + the closed form's resolution."""
    from refsim_cases.rigid.heavy_top import sleeping_threshold
    w3c = sleeping_threshold(p or base_params())
    return RESOLUTION / 2 + (FACTOR * TILT) ** 2 + (w3c * dt) ** order + LINEAR_RESOLUTION


def _find(engine, integrator, dt, variant):
    """(r found, window used, note): NaN and the reason where neither window brackets it."""
    from refsim_cases.rigid.heavy_top import find_threshold
    for low, high in (WINDOW, WIDE_WINDOW):
        try:
            found = find_threshold(engine, integrator, dt, variant, low=low, high=high,
                                   resolution=RESOLUTION, periods=PERIODS, factor=FACTOR,
                                   tilt=TILT)
            return found, (low, high), ""
        except ValueError as error:
            note = str(error)
    return math.nan, WIDE_WINDOW, note


def threshold_figure(engine_name: str, variant: str, integrator: str, dt: float) -> dict:
    """One sweep: the engine's threshold beside r_look, the bound and whether they agree."""
    from refsim.registry import get_engine
    engine = get_engine(engine_name)
    p = base_params()
    t0 = time.perf_counter()
    found, window, note = _find(engine, integrator, dt, variant)
    elapsed = time.perf_counter() - t0
    from refsim_cases.rigid.heavy_top import CASE
    sim = engine.build(CASE.scene(p), dt, integrator, variant)
    order = float(sim.settings()["integrator"]["order"])
    sim.close()
    r_look, r_exact = linear_threshold(look_times(dt, p)), linear_threshold(exact_times())
    bound = agreement_bound(order, dt, p)
    return {"figure": "sleeping_threshold", "value": float(found), "units": UNITS,
            "description": "spin ratio w3 / w3c at which the heavy top, released at 1e-3 rad, "
                           "keeps its tilt below 10x over 3 periods 2 pi / Omega_c (bisected "
                           "to 1e-3); theory 1, its linearised finite-time criterion r_look",
            "engine": engine_name, "engine_variant": variant, "integrator": integrator,
            "dt": float(dt), "time_us": elapsed * 1e6, "time_column": "time_us",
            "linear_threshold": r_look, "linear_threshold_exact_time": r_exact,
            "deviation": float(found - r_look), "bound": bound, "order": order,
            "agrees": bool(abs(found - r_look) <= bound), "window": f"{window[0]}..{window[1]}",
            "note": note, "show": ["deviation", "bound", "agrees"]}


def sweep_plan(quick: bool):
    """([(engine, variant, integrator, dt)], [(engine, reason)]) over every available engine
    that runs the top, fixed-step integrators only."""
    from refsim_cases.rigid.heavy_top import CASE
    from refsim.case import adaptive_rtol
    from refsim.registry import get_engine
    scene = CASE.scene(base_params())
    plan, skipped = [], []
    for name in ENGINES:
        engine = get_engine(name)
        reason = engine.supports(scene) if engine.available() else "not installed"
        if reason is not None:
            skipped.append((name, reason))
            continue
        variants = engine.formulations(scene)
        for variant in variants[:1] if quick else variants:
            for integrator in engine.offered_integrators(scene):
                if adaptive_rtol(integrator) is None and \
                        engine.supports(scene, integrator) is None:
                    plan.extend((name, variant, integrator, dt)
                                for dt in (QUICK_DTS if quick else DTS))
    return plan, skipped


def print_figures(figures, skipped) -> None:
    from refsim_cases.rigid.heavy_top import sleeping_threshold
    p = base_params()
    r_exact = linear_threshold(exact_times())
    print(f"sleeping top: w3c = 2 sqrt(I1' M g l) / I3 = {sleeping_threshold(p):.4f} rad/s; "
          f"theory: stable iff w3 / w3c > 1; linearised criterion (tilt < {FACTOR:g}x over "
          f"{PERIODS:g} periods) at exact times r_lin = {r_exact:.5f} in [1, "
          f"{FACTOR / math.sqrt(FACTOR ** 2 - 1):.5f}]")
    print("   engine:formulation integrator          dt      r found   r_look    r - r_look"
          "    bound  agrees   s")
    for fig in figures:
        label = f"{fig['engine']}{':' + fig['engine_variant'] if fig['engine_variant'] else ''}"
        print(f"   {label + ' ' + fig['integrator']:38s} {fig['dt']:7.0e} {fig['value']:9.5f}"
              f" {fig['linear_threshold']:9.5f} {fig['deviation']:+10.2e} {fig['bound']:9.2e}"
              f"  {'yes' if fig['agrees'] else 'NO ':4s} {fig['time_us'] / 1e6:5.1f}"
              f"{'  ' + fig['note'] if fig['note'] else ''}")
    for name, reason in skipped:
        print(f"   {name}: unsupported: {reason}")


def main(quick: bool = False) -> list[dict]:
    plan, skipped = sweep_plan(quick)
    figures = [threshold_figure(*entry) for entry in plan]
    print_figures(figures, skipped)
    return figures
