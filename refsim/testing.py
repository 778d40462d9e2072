"""Tolerance checks for pytest: run a case on an engine and assert what the case promises.

    from refsim.testing import assert_within_tolerance
    def test_my_engine_pendulum():
        assert_within_tolerance("pendulum", "my_engine", "symplectic_euler")
"""
from __future__ import annotations

from refsim.runner import Job, run_job


def accuracy(case, variant, engine, integrator, dt, engine_variant="", **params) -> dict:
    """Accuracy pass only (no timing); the results row, with the stacked observations under
    "trajectory"."""
    job = Job(case, variant, engine, engine_variant, integrator, float(dt),
              tuple(sorted(params.items())))
    return run_job(job, repeats=0, keep_trajectory=True)


def measured_order(case, variant, engine, integrator, dts, engine_variant="", **params):
    """(slope, points used, errors) of log err_max against log dt over `dts`."""
    from cases import get_case
    from refsim.metrics import convergence_order

    rows = [accuracy(case, variant, engine, integrator, dt, engine_variant, **params)
            for dt in dts]
    bad = [r["reason"] for r in rows if r["status"] != "ok"]
    if bad:
        raise AssertionError(f"{case} {engine} {integrator}: {bad[0]}")
    c = get_case(case)
    p = c.variant_params(variant, params)
    errs = [r["err_max"] for r in rows]
    order, used = convergence_order(dts, errs, c.error_floor(p), c.error_ceiling(p))
    return order, used, errs


def assert_within_tolerance(case, engine, integrator, variant=None, engine_variant="",
                            dt=None, **params) -> dict:
    """Run `case` on `engine` at the case's reference dt (or `dt`) and assert its tolerance."""
    from cases import get_case
    c = get_case(case)
    variant = variant or next(iter(c.variants))
    p = c.variant_params(variant, params)
    row = accuracy(case, variant, engine, integrator, dt or c.reference_dt(p), engine_variant,
                   **params)
    if row["status"] != "ok":
        raise AssertionError(f"{case}/{variant} on {engine} {integrator}: {row['status']} "
                             f"({row['reason']})")
    if not row["within_tol"]:
        raise AssertionError(f"{case}/{variant} on {engine} {integrator}: err_max "
                             f"{row['err_max']:.3g} > tolerance {row['tolerance']:.3g} "
                             f"({row['tol_reason']})")
    return row


def spring_stable(engine, integrator, y, energy_factor=1e4, periods=100, engine_variant="",
                  **params) -> bool:
    """Stability criterion on the undamped stiff spring at y = omega dt: finite, and the
    energy after every step below energy_factor * E0 over `periods` periods. (From rest,
    symplectic Euler's energy legitimately peaks at E0 / (1 - y/2): a factor of 10 would put
    its limit at y = 1.8, not 2.)"""
    import math

    import numpy as np

    from adapters import get_engine
    from cases import get_case
    case = get_case("stiff_spring")
    p = case.variant_params("default", params)
    sim = get_engine(engine).build(case.scene(p), y / case.omega(p), integrator, engine_variant)
    e0 = case.energy_scale(p)
    try:
        for _ in range(int(math.ceil(periods * 2 * math.pi / y))):
            sim.step(1)
            o = sim.observe()
            energy = case.energy(p, {k: np.asarray([o[k]]) for k in o})[0]
            if sim.failure or not np.isfinite(energy) or energy >= energy_factor * e0:
                return False
        return True
    finally:
        sim.close()
