"""A stretched run's timing (its first N' steps, scaled) against the accuracy pass's own step
calls over the whole run (refsim.run.timing.whole_run_check)."""
import time

import pytest

from refsim.run.job import Job
from refsim.run.timing import VARYING, timing_pass, whole_run_check


def _timing(step_s, timed, steps, call_us=50.0):
    return {"step_s": step_s, "step_s_median": step_s, "us_per_step": step_s / steps * 1e6,
            "call_us": call_us, "repeats": 2, "timed_steps": timed, "setup_s": 0.0,
            "timing": "fresh models, min of 2"}


def test_a_run_timed_whole_is_never_replaced():
    t = _timing(1.0, 1000, 1000)
    assert whole_run_check(t, 1000, 5.0, 10) == t


@pytest.mark.parametrize("whole", [1.0, 1.2, 0.8])
def test_a_stretched_figure_within_the_spread_is_kept(whole):
    t = _timing(1.0, 100, 1000)
    # 10 calls of 50 us less a 1 ms step each: no fixed cost to take off
    assert whole_run_check(t, 1000, whole, 10) == t


@pytest.mark.parametrize("whole", [1.0 + 1.5 * VARYING, 1.0 - 1.5 * VARYING])
def test_a_cost_that_varies_along_the_run_keeps_the_whole_runs_figure(whole):
    t = _timing(1.0, 100, 1000, call_us=1e3 + 100.0)  # each call adds 100 us to its steps
    out = whole_run_check(t, 1000, whole + 10 * 100e-6, 10)
    assert out["step_s"] == pytest.approx(whole, rel=1e-12)  # the calls' 1 ms taken off
    assert out["us_per_step"] == pytest.approx(whole / 1000 * 1e6, rel=1e-12)
    assert "varies along the run" in out["timing"] and "first 100 steps" in out["timing"]


def test_calls_whose_fixed_cost_dominates_are_not_read():
    # one call per step, each 0.9 ms of launch around a 0.1 ms step: the whole-run difference
    # would be launch jitter, not the steps
    t = _timing(0.1, 100, 1000, call_us=1000.0)
    assert whole_run_check(t, 1000, 1.0, 1000) == t


class _GrowingSim:
    """Each step costs more than the one before (a neighbour list that fills): step k takes
    (1 + k / 100) x 20 us, so a run's first tenth costs far less per step than the run."""

    compile_s = 0.0

    def __init__(self):
        self.k = 0

    def step(self, n):
        cost = sum(20e-6 * (1 + (self.k + i) / 100) for i in range(n))
        self.k += n
        end = time.perf_counter() + cost
        while time.perf_counter() < end:
            pass

    def close(self):
        pass


class _GrowingEngine:
    def build(self, scene, dt, integrator, variant):
        return _GrowingSim()


def test_the_check_catches_a_growing_cost_the_stretch_hides():
    """10,000 steps whose cost grows 100-fold: the first 500 steps scaled say ~0.7 s, the run
    takes ~10 s; the accuracy pass's step calls over the whole run say so (computed here, not
    run: the whole run's cost is the sum of its steps)."""
    steps, timed = 10_000, 500
    job = Job("free_fall", "default", "x", "", "rk4", 1e-3)
    t = timing_pass(_GrowingEngine(), None, job, steps=steps, timed=timed, repeats=2,
                    budget_s=0.5)
    assert t["timed_steps"] < steps
    whole = sum(20e-6 * (1 + k / 100) for k in range(steps))
    out = whole_run_check(t, steps, whole, 100)
    assert out["step_s"] == pytest.approx(whole, rel=0.01)  # the calls' fixed cost: ~0
    assert "varies along the run" in out["timing"]
