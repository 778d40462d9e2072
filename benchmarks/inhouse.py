"""`refsim bench inhouse` (the default bench): speed figures of the in-house engine, printed,
on one core, and returned as data (one dict per figure, refsim.store.figures) for the store.

1. microseconds per RK4 step on one pendulum (the engine's Sim.step);
2. pendulum-steps per second of RK4 on a batch of 10,000 pendulums (goal >= 1e7);
3. wall time to reach err_max <= 1e-8 on the 10 s pendulum (theta0 = 1 rad) with the fastest
   in-house method, against scipy's solve_ivp (DOP853) measured beside it, both producing the
   trajectory at the same 1001 sample times (goal: at most 1.0x solve_ivp's time);
4. the contact step on a box of N = 1e2, 1e3, 1e4 spheres, and the fitted cost exponent.
Times are the minimum over repeats (the least disturbed run), after a warm-up.
"""
from __future__ import annotations

import time

import numpy as np

from refsim.integrators.spec import spec_name

TARGET = 1e-8
DURATION, SAMPLE = 10.0, 0.01
W0 = np.sqrt(9.81)
THETA0 = 1.0
BOX_CASE = "sphere_box"  # N spheres in a closed box (variant box_100, n_spheres set here)


def best_time(fn, repeats=5):
    fn()  # warm-up
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def single_pendulum_rk4(steps=20000, repeats=5):
    from refsim.registry import get_case, get_engine
    case = get_case("pendulum")
    scene = case.scene(case.variant_params("default"))
    engine = get_engine("refsim")

    def run():
        engine.build(scene, 1e-3, "rk4", "generalized").step(steps)
    return best_time(run, repeats) / steps * 1e6


def batch_pendulums_rk4(n=10_000, steps=200, repeats=5):
    from refsim.integrators import get_integrator
    from refsim.models.joints import HingeSystem
    system = HingeSystem(np.array([W0 * W0]), np.array([0.0]))
    stepper = get_integrator("rk4")
    theta0 = np.linspace(0.1, 3.0, n)[:, None]

    def run():
        state = stepper.start(system, 0.0, theta0, np.zeros_like(theta0), 1e-3)
        stepper.advance(system, 0.0, state, 1e-3, steps)
    return n * steps / best_time(run, repeats)


def _samples():
    return np.arange(int(round(DURATION / SAMPLE)) + 1) * SAMPLE


def inhouse_trajectory(spec, substeps):
    """theta at the sample times, `substeps` steps of the stepper per sample interval."""
    from refsim.integrators import get_integrator
    from refsim.models.joints import HingeSystem
    system = HingeSystem(float(W0 * W0), 0.0)
    stepper = get_integrator(spec)
    h = SAMPLE / substeps
    state = stepper.start(system, 0.0, float(THETA0), 0.0, h)
    n = len(_samples())
    out = np.empty(n)
    out[0] = THETA0
    t = 0.0
    for k in range(1, n):
        t, state = stepper.advance(system, t, state, h, substeps)
        out[k] = stepper.output(system, t, state, h)[0]
    return out


def scipy_trajectory(rtol):
    from scipy.integrate import solve_ivp
    sol = solve_ivp(lambda _, y: [y[1], -W0 * W0 * np.sin(y[0])], (0.0, DURATION),
                    [THETA0, 0.0], method="DOP853", rtol=rtol, atol=rtol * 1e-3,
                    t_eval=_samples())
    return sol.y[0]


def _error(theta):
    from refsim_cases.particles.pendulum import exact_pendulum
    return float(np.max(np.abs(theta - exact_pendulum(THETA0, W0, _samples())[0])))


def _coarsest(make, settings):
    """First setting (coarse to fine) whose trajectory meets the target."""
    for s in settings:
        err = _error(make(s))
        if err <= TARGET:
            return s, err
    return None, float("nan")


def time_to_target(repeats=5):
    rows = []
    for spec, subs in (("rk4", range(1, 12)), ("dopri5", range(1, 8)),
                       ("dopri5_adaptive:1e-9", (1,)), ("dopri5_adaptive:1e-10", (1,))):
        s, err = _coarsest(lambda m, spec=spec: inhouse_trajectory(spec, m), subs)
        if s is not None:
            t = best_time(lambda: inhouse_trajectory(spec, s), repeats)
            rows.append((f"refsim {spec}, dt = {SAMPLE / s:.4g} s", err, t, spec, s))
    rtols = [10.0 ** (-k / 2) for k in range(12, 28)]
    r, err = _coarsest(scipy_trajectory, rtols)
    t_scipy = best_time(lambda: scipy_trajectory(r), repeats)
    return rows, (f"scipy solve_ivp DOP853, rtol = {r:.2g}, atol = rtol/1e3", err, t_scipy,
                  "DOP853", r)


def sphere_box_costs(sizes=(100, 1000, 10_000), steps=50, repeats=3):
    """us per step of the in-house discrete contact step on the box of N spheres, and the
    least-squares exponent of cost against N."""
    from refsim.registry import get_case, get_engine
    case, engine = get_case(BOX_CASE), get_engine("refsim")
    costs = []
    for n in sizes:
        scene = case.scene(case.variant_params("box_100", {"n_spheres": n}))
        sims = [engine.build(scene, 1e-3, "symplectic_euler", "discrete")
                for _ in range(repeats + 1)]
        sims[0].step(5)  # warm-up
        times = []
        for sim in sims[1:]:
            t0 = time.perf_counter()
            sim.step(steps)
            times.append(time.perf_counter() - t0)
        costs.append(min(times) / steps * 1e6)
    exponent = np.polyfit(np.log(sizes), np.log(costs), 1)[0]
    return list(zip(sizes, costs)), exponent


# --------------------------------------------------------------------------------------------
# The figures as data (refsim.store.figures: one stored row each)
# --------------------------------------------------------------------------------------------
def single_figure(us, steps, repeats) -> dict:
    return {"figure": "rk4_one_pendulum", "value": us, "units": "us/step",
            "description": "RK4 on one pendulum through the engine's Sim.step (generalized "
                           "hinge formulation), min over repeats after a warm-up",
            "engine": "refsim", "engine_variant": "generalized", "integrator": "rk4",
            "dt": 1e-3, "steps": steps, "us_per_step": us, "step_s": us * steps * 1e-6,
            "repeats": repeats, "measured_on": "pendulum"}


def batch_figure(rate, n, steps, repeats) -> dict:
    step_s = n * steps / rate
    return {"figure": f"rk4_batch_{n}_pendulums", "value": rate, "units": "pendulum-steps/s",
            "description": f"RK4 stepper on a batch of {n} pendulums (HingeSystem, one array "
                           "per step; goal >= 1e7 pendulum-steps/s); us_per_step is one step "
                           "of the whole batch", "engine": "refsim", "integrator": "rk4",
            "dt": 1e-3, "steps": steps, "us_per_step": step_s / steps * 1e6,
            "step_s": step_s, "repeats": repeats, "goal": 1e7, "show": ["goal"]}


def target_figures(rows, scipy_row, repeats) -> list[dict]:
    """Figure 3: the wall time of one trajectory reaching err_max <= TARGET, per method; its
    time is not per step (the method picks its own dt), so compare judges `time_us`."""
    n = len(_samples()) - 1
    figures = []
    for label, err, t, spec, substeps in rows:
        adaptive = spec_name(spec).endswith("_adaptive")
        figures.append(_target_figure(
            label, err, t, "refsim", spec, repeats, vs_solve_ivp=t / scipy_row[2],
            steps=0 if adaptive else n * substeps,
            dt_found=np.nan if adaptive else SAMPLE / substeps))
    label, err, t, method, rtol = scipy_row
    figures.append(_target_figure(label, err, t, "scipy", method, repeats, rtol=rtol))
    return figures


def _target_figure(label, err, t, engine, integrator, repeats, **extra) -> dict:
    return {"figure": f"time_to_{TARGET:g}", "value": t * 1e3, "units": "ms",
            "description": f"wall time to reach err_max <= {TARGET:g} on the 10 s pendulum "
                           "(theta0 = 1 rad) at 1001 sample times, the coarsest setting of "
                           "each method that does; scipy solve_ivp DOP853 measured beside",
            "engine": engine, "integrator": integrator, "label": label,
            "err_reached": err, "time_us": t * 1e6, "time_column": "time_us",
            "step_s": t, "repeats": repeats, "measured_on": "pendulum",
            "show": ["label", "err_reached", "vs_solve_ivp"], **extra}


def box_figures(rows, exponent, steps, repeats) -> list[dict]:
    return [{"figure": f"contact_box_{n}", "value": us, "units": "us/step",
             "description": f"in-house discrete contact step on a closed box of {n} spheres "
                            "(e = 1, volume fraction 0.05); cost_exponent: least-squares "
                            "slope of cost against N over the sizes run (goal <= 1.2)",
             "engine": "refsim", "engine_variant": "discrete",
             "integrator": "symplectic_euler", "dt": 1e-3, "steps": steps,
             "us_per_step": us, "step_s": us * steps * 1e-6, "repeats": repeats,
             "ns_per_sphere_step": us / n * 1e3, "cost_exponent": float(exponent),
             "measured_on": BOX_CASE, "show": ["ns_per_sphere_step", "cost_exponent"]}
            for n, us in rows]


def main(quick: bool = False) -> list[dict]:
    """Print the four figures; return them as data (benchmarks.inhouse_figures), which
    `refsim bench` stores as a run."""
    import os
    repeats = 3 if quick else 5
    print(f"refsim bench (one core: OMP/OPENBLAS threads = {os.environ.get('OMP_NUM_THREADS')})")
    steps = 5000 if quick else 20000
    us = single_pendulum_rk4(steps, repeats)
    print(f"1. RK4 on one pendulum (engine Sim.step):        {us:8.2f} us/step")
    figures = [single_figure(us, steps, repeats)]
    batch, batch_steps = 10_000, 50 if quick else 200
    rate = batch_pendulums_rk4(batch, batch_steps, repeats)
    print(f"2. RK4 on a batch of 10,000 pendulums:         {rate:10.3e} pendulum-steps/s "
          f"(goal >= 1e7)")
    figures.append(batch_figure(rate, batch, batch_steps, repeats))
    rows, scipy_row = time_to_target(repeats)
    print(f"3. time to err_max <= {TARGET:g} on the 10 s pendulum (theta0 = 1), "
          f"1001 samples:")
    for label, err, t, *_ in rows + [scipy_row]:
        print(f"   {label:45s} err_max {err:8.2e}  {t * 1e3:8.2f} ms")
    best = min(rows, key=lambda r: r[2])
    print(f"   fastest in-house / solve_ivp: {best[2] / scipy_row[2]:.2f}x "
          f"({best[0]}; goal <= 1.0x, aim 0.5x)")
    figures += target_figures(rows, scipy_row, repeats)
    box_steps = 20 if quick else 50
    rows, exponent = sphere_box_costs(steps=box_steps, repeats=repeats)
    print("4. contact step, box of N spheres (discrete, e = 1, volume fraction 0.05):")
    for n, us in rows:
        print(f"   N = {n:6d}: {us:10.1f} us/step  ({us / n * 1e3:7.1f} ns per sphere-step)")
    print(f"   cost exponent (least squares, N = {rows[0][0]}..{rows[-1][0]}): {exponent:.2f} "
          f"(goal <= 1.2)")
    return figures + box_figures(rows, exponent, box_steps, repeats)
