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
    (1 + k / 20) x 20 us, so a run's first quarter costs far less per step than the run."""

    compile_s = 0.0

    def __init__(self):
        self.k = 0

    def step(self, n):
        cost = sum(20e-6 * (1 + (self.k + i) / 20) for i in range(n))
        self.k += n
        end = time.perf_counter() + cost
        while time.perf_counter() < end:
            pass

    def close(self):
        pass


class _GrowingEngine:
    def build(self, scene, dt, integrator, variant):
        return _GrowingSim()


@pytest.mark.slow  # 2.3 s: the growing run is stepped for real, once scaled, once whole
def test_the_check_catches_a_growing_cost_the_stretch_hides():
    """2,000 steps whose cost grows 100-fold: the first 500 steps scaled say ~0.5 s, the run
    takes ~2 s; the accuracy pass's step calls over the whole run say so (the accuracy
    pass's figure computed as the sum of its steps; a fresh model's whole run confirms it)."""
    steps, timed = 2_000, 500
    job = Job("free_fall", "default", "x", "", "rk4", 1e-3)
    t = timing_pass(_GrowingEngine(), None, job, steps=steps, timed=timed, repeats=2,
                    budget_s=0.5)
    assert t["timed_steps"] < steps
    whole = sum(20e-6 * (1 + k / 20) for k in range(steps))
    from refsim.run.timing import whole_run_s
    out = whole_run_check(t, steps, whole, 100,
                          confirm=lambda: whole_run_s(_GrowingEngine(), None, job, steps))
    # the smaller of the two measures of the whole run: its computed cost or above it
    assert whole <= out["step_s"] <= 1.5 * whole
    assert "varies along the run" in out["timing"] and "confirmed" in out["timing"]


def test_a_busy_machine_slowing_the_accuracy_pass_is_not_taken_for_a_varying_cost():
    """The accuracy pass took 2x (another process shared the core); a fresh model's whole run
    takes what the scaled figure says: the scaled figure stays, and `timing` says why."""
    t = _timing(1.0, 100, 1000)
    out = whole_run_check(t, 1000, 2.0, 10, confirm=lambda: 1.05)
    assert out["step_s"] == 1.0 and "confirmed the scaled figure" in out["timing"]


def test_a_confirmed_varying_cost_keeps_the_smaller_whole_run_figure():
    t = _timing(1.0, 100, 1000)
    out = whole_run_check(t, 1000, 2.0, 10, confirm=lambda: 1.8)
    assert out["step_s"] == 1.8 and "confirmed by a fresh model" in out["timing"]


def test_a_run_too_long_to_repeat_is_not_repeated():
    from refsim.run.timing import CONFIRM_S
    t = _timing(CONFIRM_S, 100, 1000)
    called = []
    out = whole_run_check(t, 1000, 2 * CONFIRM_S, 10, confirm=lambda: called.append(1))
    assert not called and out["step_s"] == 2 * CONFIRM_S
    assert "one measurement, too long to repeat" in out["timing"]
