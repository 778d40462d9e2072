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
