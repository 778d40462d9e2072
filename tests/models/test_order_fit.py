"""The measured convergence order: fitted only over a decade of asymptotic dts above the error
floor, with its standard error; otherwise NaN with the reason, never a wrong number."""
import json

import numpy as np
import pandas as pd
import pytest

from refsim.run.metrics import (AT_FLOOR, PRE_ASYMPTOTIC, SHORT_SWEEP, fit_order)
from refsim.run.runner import ADAPTIVE_NOTE, SINGLE_DT_NOTE, expand, with_orders

DTS = 1e-3 * 2.0 ** np.arange(6)  # 1..32 ms: 1.5 decades


def test_exact_power_law_gives_its_order_with_zero_stderr():
    fit = fit_order(DTS, 3.0 * DTS ** 2, floor=1e-14, ceiling=1.0)
    assert fit.order == pytest.approx(2.0, abs=1e-12)
    assert fit.stderr < 1e-12 and fit.points == 6 and fit.note == ""


def test_stderr_is_the_least_squares_slope_standard_error():
    noise = np.array([1.02, 0.97, 1.01, 0.99, 1.03, 0.98])
    errs = 3.0 * DTS ** 2 * noise
    fit = fit_order(DTS, errs, floor=1e-14, ceiling=1.0)
    x, y = np.log(DTS), np.log(errs)
    slope, intercept = np.polyfit(x, y, 1)
    residual = y - slope * x - intercept
    expected = np.sqrt(residual @ residual / (len(x) - 2) / np.sum((x - x.mean()) ** 2))
    assert fit.order == pytest.approx(slope, rel=1e-12)
    assert fit.stderr == pytest.approx(expected, rel=1e-9) and fit.stderr > 0


def test_points_at_the_floor_are_left_out_and_the_rest_must_span_a_decade():
    errs = np.maximum(DTS ** 4, 1e-11)  # the two finest sit on a round-off floor of 1e-11
    fit = fit_order(DTS, errs, floor=2e-11, ceiling=1.0)
    assert np.isnan(fit.order) and fit.note == AT_FLOOR  # 4..32 ms: under a decade left
    longer = 1e-3 * 2.0 ** np.arange(8)
    fit = fit_order(longer, np.maximum(longer ** 4, 1e-11), floor=2e-11, ceiling=1.0)
    assert fit.order == pytest.approx(4.0, abs=1e-9) and fit.points == 6


def test_a_flattened_fine_end_is_not_fitted_around():
    """Round-off just above the declared floor bends the finest slope: the asymptotic range
    starts at the finest clean dt, so no fit may leave it out and report the coarse slope."""
    errs = DTS ** 4 + 5e-11
    fit = fit_order(DTS, errs, floor=1e-11, ceiling=1.0)
    assert np.isnan(fit.order) and fit.note == PRE_ASYMPTOTIC


def test_errors_above_the_ceiling_are_pre_asymptotic():
    fit = fit_order(DTS, 10 * DTS, floor=1e-14, ceiling=0.1)
    assert np.isnan(fit.order) and fit.note == PRE_ASYMPTOTIC  # 1..8 ms below it: 0.9 decade
    fit = fit_order(DTS, 2 * DTS, floor=1e-14, ceiling=0.1)
    assert fit.order == pytest.approx(1.0) and fit.points == 6


def test_a_slope_above_the_nominal_order_is_reported_as_fitted():
    """A clean slope of 5 is a 5, whatever the method's order (the verdicts compare it with
    the method's order; refsim.verdicts): it is never relabelled, and its dt range is kept."""
    fit = fit_order(DTS, DTS ** 5, floor=1e-20, ceiling=1.0)
    assert fit.order == pytest.approx(5.0) and fit.note == ""
    assert (fit.dt_lo, fit.dt_hi) == (DTS.min(), DTS.max())


def test_drifting_local_slopes_are_pre_asymptotic():
    errs = DTS ** 2 * (1 + (DTS / 0.004) ** 2)  # local slopes 2.2 at the fine end, 3.9 coarse
    fit = fit_order(DTS, errs, floor=1e-14, ceiling=1.0)
    assert np.isnan(fit.order) and fit.note == PRE_ASYMPTOTIC


def test_a_clean_sweep_under_a_decade_says_so():
    fit = fit_order(DTS[:3], DTS[:3] ** 2, floor=1e-14, ceiling=1.0)
    assert np.isnan(fit.order) and fit.note == SHORT_SWEEP


def _rows(integrator, dts, errs, status="ok", nominal=2.0):
    return [{"case": "stiff_spring", "variant": "default", "engine": "refsim",
             "engine_variant": "", "integrator": integrator, "params": json.dumps({}),
             "status": status, "dt": dt, "err_max": err, "nominal_order": nominal}
            for dt, err in zip(dts, errs)]


def test_with_orders_fills_order_stderr_points_and_note_per_group():
    dts = 1e-4 * 2.0 ** np.arange(5)  # 0.1..1.6 ms on the k = 1e4 spring: w dt <= 0.16
    table = pd.DataFrame(_rows("rk2", dts, 1e3 * dts ** 2)
                         + _rows("dopri5_adaptive:1e-9", dts, 1e3 * dts ** 5)
                         + _rows("heun", dts[:1], [1e-3])
                         + _rows("midpoint", dts, [np.nan] * 5, status="diverged"))
    out = with_orders(table)
    rk2 = out[out.integrator == "rk2"]
    assert np.allclose(rk2.order, 2.0) and (rk2.order_points == 5).all()
    assert (rk2.order_note == "").all() and (rk2.order_stderr < 1e-9).all()
    adaptive = out[out.integrator.str.startswith("dopri5")]
    assert adaptive.order.isna().all() and (adaptive.order_note == ADAPTIVE_NOTE).all()
    assert (out[out.integrator == "heun"].order_note == SINGLE_DT_NOTE).all()
    failed = out[out.integrator == "midpoint"]
    assert failed.order.isna().all() and (failed.order_note == "").all()


def test_order_dts_run_untimed_and_only_in_the_default_formulation():
    jobs = expand(["pendulum"], ["refsim"], variants=["default"])
    untimed = [j for j in jobs if not j.timed]
    assert {j.dt for j in untimed} == {5e-2, 1.25e-2}
    assert {j.engine_variant for j in untimed} == {"generalized"}
    assert not any(j.integrator.endswith("_adaptive") for j in untimed)
    assert all(j.timed for j in expand(["pendulum"], ["refsim"], quick=True))
    assert all(j.timed for j in expand(["pendulum"], ["refsim"], dts=[1e-3]))


def test_an_untimed_job_has_no_timing_pass():
    from refsim.run.job import Job, run_job
    job = Job("pendulum", "default", "refsim", "generalized", "rk4", 5e-2, timed=False)
    row = run_job(job, repeats=3)
    assert row["status"] == "ok" and row["repeats"] == 0 and np.isnan(row["step_s"])
