"""The timing pass of a job: fresh models stepped with nothing observed, repeated until the
figure is stable (refsim.run.job runs it after the accuracy pass, which is its warm-up)."""
from __future__ import annotations

import time

import numpy as np

# The timing pass steps fresh models with nothing observed, repeating until the figure is
# stable (see timing_pass). A run whose accuracy pass spent over LONG_RUN_S inside step calls
# is timed over its first N' steps only, N' chosen so that one timed run takes about
# LONG_RUN_S, and scaled to the whole run (`timed_steps` says N'); the accuracy pass never
# gives the timing sample (its step calls are one per observation: a taichi kernel launch
# each, 0.4 ms against 0.9 us per step inside one launch, measured on newtons_cradle).
# 0.1 s a timed run: the scheduler's jitter (a few ms a second on a quiet 2-core machine) is a
# few per cent of it, below the spread at which repeats stop.
LONG_RUN_S = 0.1
# Repeats stop once the median of the timed runs is within TIMING_SPREAD of their min (at
# least two runs), or past BUDGET_S of timed runs while unsettled (`timing` says so).
TIMING_SPREAD = 0.05
BUDGET_S = 0.5
PROBES = 4  # probe calls at most to size N' (each grows it by LONG_RUN_S / its time)
# a run whose 1-step call takes over this share of its whole call is call-dominated, said
# in `timing`: its us_per_step is mostly the call's fixed cost (taichi newtons_cradle: a
# 400-800 us launch and sync, +-300 us, against 125-700 us of steps in the whole run)
CALL_DOMINATED = 0.5
# A stretched run (timed over its first N' steps, scaled) is checked against the accuracy
# pass's own step calls over the whole run, net of their fixed cost: where
# the two differ by more than VARYING the per-step cost changes along the run, and the whole
# run's figure is the one kept (`timing` says so). Measured: the SPH dam break's neighbour
# count grows as the column collapses, its first 19 of 8268 steps scaled gave 24.2 s where the
# run's step calls took 41.6 s. 25 %: above the spread between one untimed pass and the min
# of the repeats on a busy 2-core machine (see whole_run_check's test).
VARYING = 0.25
CONFIRM_S = 5.0  # the longest whole run repeated on a fresh model to confirm a difference


def build_sim(engine, scene, job):
    """A fresh Sim of the job and its setup time (compilation apart)."""
    t0 = time.perf_counter()
    sim = engine.build(scene, job.dt, job.integrator, job.engine_variant)
    return sim, time.perf_counter() - t0 - sim.compile_s


def timing_pass(engine, scene, job, steps, timed, repeats, budget_s):
    """Fresh models each stepped `timed` steps in one call, nothing observed inside the timed
    region, and as many fresh models stepped one step in one call (`call_us`: the fixed cost
    of a call, e.g. a kernel launch and sync). us_per_step is what a step costs when the run
    is stepped in one call, the call's fixed cost included (min over the fresh models / N'):
    the engine's real cost of the run, never the harness's. A call-dominated run (its 1-step
    call over CALL_DOMINATED of the whole call) says so in `timing`; its marginal per-step cost
    is below the call's jitter. A run of `steps` is scaled from its first `timed` steps. The
    accuracy pass just ran the same code on the same scene and step: it is the warm-up
    (compilation, caches, lazy imports).

    Repeats stop when the figure is stable: at least min(2, `repeats`) timed runs, then more
    (up to `repeats`) only while the median is over TIMING_SPREAD above the min and the timed
    runs have taken less than `budget_s`; `timing` gives the count and the spread, and says
    `unsettled` when it stopped above it. The probe that sized N' is itself the first timed
    run when its N is the final one."""
    timed, times = _probe_stretch(engine, scene, job, steps, timed)
    ones, setups, spent = [], [], sum(times)
    least = min(2, max(1, repeats))
    while len(times) < max(1, repeats) and not (
            len(times) >= least and (_spread(times) <= TIMING_SPREAD or spent >= budget_s)):
        elapsed, setup_s = timed_run(engine, scene, job, timed)
        times.append(elapsed)
        setups.append(setup_s)
        spent += elapsed
    while len(ones) < len(times):
        elapsed, setup_s = timed_run(engine, scene, job, 1)
        ones.append(elapsed)
        setups.append(setup_s)
    best, call, spread = min(times), min(ones), _spread(times)
    scale = steps / timed
    stretch = "" if timed == steps else f", first {timed} of {steps} steps, scaled"
    settled = ("" if len(times) < 2 else f", median {100 * spread:.2g} % above it" + (
        "" if spread <= TIMING_SPREAD else " (unsettled)"))
    dominated = (f"; call-dominated: a 1-step call takes {call * 1e6:.3g} us of its "
                 f"{best * 1e6:.3g} us" if timed > 1 and call > CALL_DOMINATED * best else "")
    return {"step_s": best * scale, "step_s_median": float(np.median(times)) * scale,
            "us_per_step": best / timed * 1e6, "call_us": call * 1e6, "repeats": len(times),
            "timed_steps": timed, "setup_s": min(setups),
            "timing": f"fresh models, min of {len(times)}{settled}{stretch}{dominated}"}


def timed_run(engine, scene, job, steps) -> tuple[float, float]:
    """(time of one fresh model stepped `steps` steps in one call, nothing observed; its
    setup time)."""
    sim, setup_s = build_sim(engine, scene, job)
    t0 = time.perf_counter()
    sim.step(steps)
    elapsed = time.perf_counter() - t0
    sim.close()
    return elapsed, setup_s


def whole_run_s(engine, scene, job, steps) -> float:
    """The time of one fresh model stepped over the whole run in one call."""
    return timed_run(engine, scene, job, steps)[0]


def _spread(times) -> float:
    """(median - min) / min of the timed runs (0 for one run)."""
    best = min(times)
    return float(np.median(times)) / best - 1.0 if best > 0 else 0.0


def _probe_stretch(engine, scene, job, steps, timed):
    """N' came from the accuracy pass, whose per-observation calls (a kernel launch each) may
    dwarf the stepping: probe calls of N' steps, N' grown to what fits LONG_RUN_S by each
    measure (the whole run when it fits), at most PROBES of them. Returns N' and the probe's
    time as the first timed run when the last probe ran the final N' ([] otherwise)."""
    for _ in range(PROBES):
        probe = timed_run(engine, scene, job, timed)[0]
        if timed >= steps or probe >= LONG_RUN_S / 4:
            return timed, [probe]
        timed = min(steps, int(timed * LONG_RUN_S / max(probe, 1e-9)))
    return timed, []


def whole_run_check(timing: dict, steps: int, stepping_s: float, calls: int,
                    confirm=None) -> dict:
    """`timing` (timing_pass's figures) unchanged unless the run was stretched and the
    accuracy pass's `calls` step calls, which took `stepping_s` over all `steps`, give a whole
    run more than VARYING away from the scaled figure once their fixed cost (calls x (call_us
    - us_per_step): a 1-step call's cost beyond its step) is taken off. That pass is one
    measurement: a busy machine slows it by as much (measured: 1.5-4.5x on rows of a steady
    per-step cost while other work shared the two cores). So a difference is confirmed by
    `confirm()`, the time of one fresh model stepped over the whole run in one call (None
    where that would exceed CONFIRM_S: the accuracy pass's figure stands alone, and `timing`
    says so); the whole run's figure is the smaller of the two, kept only where it still
    differs by over VARYING. Not where the calls' fixed cost is over VARYING of their time
    (one call per step or so: the difference would be the call's jitter)."""
    timed, scaled = timing["timed_steps"], timing["step_s"]
    if timed >= steps or not (scaled > 0) or not (stepping_s > 0):
        return timing
    # a 1-step call's cost less one step's: what each call adds to the steps it runs
    fixed = calls * max(0.0, timing["call_us"] - timing["us_per_step"]) * 1e-6
    if fixed > VARYING * stepping_s:
        return timing
    whole = stepping_s - fixed
    if abs(whole / scaled - 1.0) <= VARYING:
        return timing
    fresh = confirm() if confirm is not None and whole <= CONFIRM_S else None
    if fresh is not None:
        whole = min(whole, fresh)
        if abs(whole / scaled - 1.0) <= VARYING:
            return {**timing, "timing": timing["timing"] + (
                f"; a whole run of a fresh model ({fresh:.3g} s) confirmed the scaled figure "
                "against the accuracy pass's")}
    how = ("confirmed by a fresh model's whole run" if fresh is not None else
           "one measurement, too long to repeat")
    return {**timing, "step_s": whole, "step_s_median": whole,
            "us_per_step": whole / steps * 1e6,
            "timing": timing["timing"] + (
                f"; the per-step cost varies along the run: its first {timed} steps scaled "
                f"give {scaled:.3g} s, the whole run {whole:.3g} s ({how}), the whole run's "
                "figure kept")}
