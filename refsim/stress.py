"""`refsim stress`: stability limits and a stiffness sweep on the undamped stiff spring.

1. Stability limits. For every engine and every fixed-step integrator it offers (adaptive ones
   and those `supports` rejects are skipped): the largest stable y = omega dt, by bisection
   (refsim.stress_search: batched over y in the in-house engine, one Sim per y elsewhere).
   Criterion: stable when, at every step over P periods (default 1000; at most 10 P steps),
   the state is finite, the engine reports no failure and the energy stays below F E0,
   F = 1e4 (`Criterion.text`, `f_reason`). Scene: the stiff-spring case with amplitude 1e-7 m,
   other parameters default, so the spring stays linear (stress_search.SPRING_PARAMS says
   why); the sweep uses the same. Columns: measured limit; theory (from the stepper's
   declared family / tableau: symplectic Euler, Verlet 2; RK4 2 sqrt 2; dopri5 0.99719;
   explicit Euler, midpoint, Heun, RK2 0; implicit unbounded);
   finite_time, the y the stated criterion must give from the method's exact step map;
   resolution = |finite_time - theory| plus the overshoot allowance; agrees: |measured -
   theory| <= resolution + bisection tolerance x max(1, theory), or both unbounded.
2. Stiffness sweep. k = 1e1 .. 1e8 N/m (m = 1 kg, y = sqrt(k) dt) at dt = 1e-3 s (--dt), on
   every engine's default integrator (symplectic Euler where offered, else its first) and the
   named ones it offers (SWEEP_NAMED), each run min(20 periods, 2 s) observed every step.
3. Failure taxonomy (column `failure`, `LEGEND`): each run goes to its end, or until the
   engine reports a failure or the state turns non-finite; the most telling label wins:
   - silent_reset: the engine reported a state on which it silently resets (MuJoCo's bad
     qpos/qvel/qacc warning: MuJoCo would reset to the initial pose and go on; the adapter
     turns the reset off and reports it as `Sim.failure`), or the state returned bitwise to
     the initial one after the energy had reached F E0;
   - engine_failure: any other breakdown the engine reported (`Sim.failure`, e.g. refsim's
     Newton non-convergence);
   - nan_inf: a non-finite position or velocity;
   - energy_growth: energy >= F E0 at some step, the state still finite;
   - artificial_damping: none of the above, and energy < 1 % of E0 at the end (undamped run);
   - none: none of these; error: the run raised (not a physics outcome).
   `at_step` is the step of the labelled event; `detail` the engine's message and when the
   energy first reached F E0.
4. Store: stress_limits.csv, stress_sweep.csv and manifest.json in a new run directory under
   --out (default reports/runs), and the same figures as an ordinary stored run there
   (results.csv, rows.jsonl, cases.json: refsim.stress_store) that `refsim report` and
   `refsim compare` read; both tables are printed with the directory. Exit 0: a measured
   instability is data.
"""
from __future__ import annotations

import argparse
import math
import os
import shlex
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from refsim import store
from refsim.stress_report import atomic_csv, print_report
from refsim.stress_store import store_run
from refsim.integrators import get_integrator
from refsim.stress_search import (ENERGY_FACTOR, Y_MAX, Y_MIN, Criterion, Spring, find_limit,
                                  finite_time, refsim_equivalent, theory)

PERIODS, QUICK_PERIODS = 1000, 100
TOL, QUICK_TOL = 1e-5, 1e-3  # bisection tolerance, relative to max(1, y)
SWEEP_K = tuple(10.0 ** np.arange(1, 9))
SWEEP_DT, SWEEP_PERIODS, SWEEP_SPAN, QUICK_SPAN = 1e-3, 20, 2.0, 0.5
SWEEP_NAMED = ("symplectic_euler", "explicit_euler", "rk4", "implicit_euler", "discrete")
DAMPED_FRACTION = 0.01
MAX_PERIODS = 100_000
# MuJoCo's warnings on which it resets to the initial pose (the adapter disables the reset
# and reports the warning as Sim.failure)
RESET_WARNINGS = ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC")
LEGEND = {
    "silent_reset": "the engine reported a state on which it silently resets (MuJoCo's bad "
                    "qpos/qvel/qacc warning; the adapter turns the reset off and reports it), "
                    "or the state returned bitwise to the initial one after E >= F E0",
    "engine_failure": "the engine reported another breakdown (Sim.failure, e.g. refsim's "
                      "Newton non-convergence)",
    "nan_inf": "a non-finite position or velocity",
    "energy_growth": f"energy >= F E0 = {ENERGY_FACTOR:g} E0 at some step, state finite",
    "artificial_damping": f"none of the above, and energy < {DAMPED_FRACTION:.0%} of E0 at the "
                          "end of the undamped run",
    "none": "none of the above",
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--engine", action="append",
                        help="engine (repeatable; default: every available engine)")
    parser.add_argument("--integrator", action="append",
                        help="integrator (repeatable; default: every fixed-step one offered)")
    parser.add_argument("--periods", default=None,
                        help=f"periods judged per y in the limit search, at most 10 steps "
                             f"each (default {PERIODS}, --quick {QUICK_PERIODS})")
    parser.add_argument("--dt", default=None, help=f"sweep time step in s (default {SWEEP_DT})")
    parser.add_argument("--quick", action="store_true",
                        help=f"{QUICK_PERIODS} periods, bisection to {QUICK_TOL:g}, "
                             f"sweep runs of at most {QUICK_SPAN} s")
    parser.add_argument("--out", default=None, help="runs directory (default reports/runs)")


def main(args) -> int:
    opts = options(args)
    t0 = time.perf_counter()
    spring = Spring()
    st = store.RunStore.create(opts["out"], manifest(opts))
    limits = limits_table(opts, spring)
    atomic_csv(st.dir / "stress_limits.csv", limits)
    sweep = sweep_table(opts)
    atomic_csv(st.dir / "stress_sweep.csv", sweep)
    store_run(st, opts, spring, limits, sweep)
    st.update_manifest(status="complete", wall_s=round(time.perf_counter() - t0, 2))
    print_report(opts, spring, limits, sweep)
    print(st.dir)
    return 0


# --------------------------------------------------------------------------------------------
# Options
# --------------------------------------------------------------------------------------------
def options(args) -> dict:
    """Validated options; ValueError naming the parameter and its valid range otherwise."""
    quick = bool(getattr(args, "quick", False))
    engines = _engines(getattr(args, "engine", None))
    periods = _periods(getattr(args, "periods", None), QUICK_PERIODS if quick else PERIODS)
    return {"engines": engines, "integrators": _integrators(getattr(args, "integrator", None),
                                                            engines),
            "criterion": Criterion(periods), "tol": QUICK_TOL if quick else TOL,
            "dt": _dt(getattr(args, "dt", None)), "quick": quick,
            "span": QUICK_SPAN if quick else SWEEP_SPAN,
            "out": Path(getattr(args, "out", None) or store.DEFAULT_ROOT)}


def _engines(names):
    from refsim.registry import engine_names, get_engine
    known = engine_names()
    for name in names or []:
        if name not in known:
            raise ValueError(f"--engine must be one of {known}, got {name!r}")
        if not get_engine(name).available():
            raise ValueError(f"--engine {name!r} is not available (its package does not "
                             f"import); available: {_available(known)}")
    return list(dict.fromkeys(names)) if names else _available(known)


def _available(names):
    from refsim.registry import get_engine
    return [n for n in names if get_engine(n).available()]


def _integrators(names, engines):
    if not names:
        return None
    from refsim.registry import get_engine
    offered = list(dict.fromkeys(i for e in engines for i in get_engine(e).integrators))
    for name in names:
        if name.partition(":")[0] not in offered:
            raise ValueError(f"--integrator must be one offered by {engines}: {offered}; "
                             f"got {name!r}")
        eq = refsim_equivalent(None, name)
        if eq is not None and get_integrator(eq).adaptive:
            raise ValueError(f"--integrator {name!r} is adaptive (no fixed dt, so no limit in "
                             "y = omega dt): choose a fixed-step integrator")
    return list(dict.fromkeys(names))


def _periods(value, default):
    if value is None:
        return default
    text = str(value).strip()
    if not text.isdigit() or not 1 <= int(text) <= MAX_PERIODS:
        raise ValueError(f"--periods must be an integer in [1, {MAX_PERIODS}], got {value!r}")
    return int(text)


def _dt(value):
    if value is None:
        return SWEEP_DT
    try:
        dt = float(value)
    except (TypeError, ValueError):
        dt = math.nan
    if not math.isfinite(dt) or not 0 < dt <= 1:
        raise ValueError(f"--dt must be a number of seconds in (0, 1], got {value!r}")
    return dt


def manifest(opts) -> dict:
    from refsim.registry import get_engine
    from refsim.stress_search import probe_case
    versions = {e: get_engine(e).version() for e in opts["engines"]}
    threads = os.environ.get("OMP_NUM_THREADS", "1")
    probe = probe_case()
    env = store.environment(versions, {probe.name: probe.source_hash()},
                            int(threads) if threads.isdigit() else 1)
    return {"run_id": store.new_run_id(), "kind": "stress", "command": command(opts),
            "argv": sys.argv, "criterion": opts["criterion"].text(),
            "options": {"engines": opts["engines"], "integrators": opts["integrators"],
                        "periods": opts["criterion"].periods, "tol": opts["tol"],
                        "sweep_dt": opts["dt"], "sweep_k": list(SWEEP_K),
                        "sweep_span_s": opts["span"], "quick": opts["quick"]},
            "status": "running", **env}


def command(opts) -> str:
    parts = ["refsim", "stress"]
    for e in opts["engines"]:
        parts += ["--engine", e]
    for i in opts["integrators"] or []:
        parts += ["--integrator", i]
    parts += ["--periods", str(opts["criterion"].periods), "--dt", f"{opts['dt']:g}"]
    parts += ["--quick"] if opts["quick"] else []
    return shlex.join(parts + ["--out", str(opts["out"])])


# --------------------------------------------------------------------------------------------
# 1. Stability limits
# --------------------------------------------------------------------------------------------
def limit_jobs(opts, spring) -> tuple[list, list]:
    """([(engine, integrator)] to search, ["engine integrator (why skipped)"]): fixed-step
    integrators the engine supports on the spring, those of --integrator if given."""
    from refsim.registry import get_engine
    jobs, skipped = [], []
    for name in opts["engines"]:
        engine = get_engine(name)
        for integ in opts["integrators"] or engine.integrators:
            if integ.partition(":")[0] not in engine.integrators:
                continue
            eq = refsim_equivalent(engine, integ)
            why = "adaptive" if eq and get_integrator(eq).adaptive else \
                engine.supports(spring.scene, integ)
            if why:
                skipped.append(f"{name} {integ} ({why})")
            else:
                jobs.append((engine, integ))
    return jobs, skipped


def limits_table(opts, spring) -> pd.DataFrame:
    jobs, skipped = limit_jobs(opts, spring)
    for line in skipped:
        print(f"stress: skipped {line}", file=sys.stderr)
    return pd.DataFrame([limit_row(e, i, spring, opts) for e, i in jobs])


def limit_row(engine, integrator, spring, opts) -> dict:
    crit, tol = opts["criterion"], opts["tol"]
    eq = refsim_equivalent(engine, integrator)
    stepper = get_integrator(eq) if eq else None
    th = theory(stepper) if stepper else math.nan
    ft, res = finite_time(stepper, th, crit) if stepper else (math.nan, math.nan)
    row = {"engine": engine.name, "integrator": integrator,
           "as": eq if eq != integrator else "", "measured": math.nan, "theory": th,
           "finite_time": ft, "resolution": res}
    try:
        found = find_limit(engine, integrator, spring, crit, tol)
    except Exception as exc:  # a failure is a row, never a crash of the run
        return {**row, "agrees": False, "note": f"error: {type(exc).__name__}: {exc}"}
    row.update(measured=found.limit, agrees=agrees(found.limit, th, res, tol),
               evals=found.evaluations, batched=found.batched, seconds=round(found.seconds, 2))
    print(f"stress: {engine.name} {integrator}: limit {found.limit:.7g} "
          f"({found.seconds:.1f} s)", file=sys.stderr, flush=True)
    return {**row, "note": limit_note(found, th, res)}


def agrees(measured, th, res, tol):
    if math.isnan(th):
        return None
    if math.isinf(th) or math.isinf(measured):
        return bool(measured == th)
    return bool(abs(measured - th) <= res + tol * max(1.0, th))


def limit_note(found, th, res) -> str:
    notes = []
    if th == 0:
        notes.append("unstable at every y (finite-time criterion)")
    elif 0 < th < math.inf and res > 1e-2:
        notes.append("criterion-limited (slow growth past the limit)")
    if math.isinf(found.limit):
        notes.append(f"stable to {Y_MAX:g}")
    elif found.limit == 0:
        notes.append(f"unstable down to {Y_MIN:g}")
    if found.fallback:
        notes.append("one Sim per y (array h fails)")
    return "; ".join(notes)


# --------------------------------------------------------------------------------------------
# 2. Stiffness sweep
# --------------------------------------------------------------------------------------------
def sweep_integrators(engine, requested=None):
    """Default (symplectic Euler where offered, else the first) and the named ones offered."""
    if requested:
        return [i for i in requested if i.partition(":")[0] in engine.integrators]
    default = "symplectic_euler" if "symplectic_euler" in engine.integrators \
        else engine.integrators[0]
    return [default] + [i for i in SWEEP_NAMED if i in engine.integrators and i != default]


def sweep_table(opts, ks=SWEEP_K) -> pd.DataFrame:
    from refsim.registry import get_engine
    rows = []
    for name in opts["engines"]:
        engine = get_engine(name)
        for integ in sweep_integrators(engine, opts["integrators"]):
            rows += [sweep_row(engine, integ, k, opts["dt"], opts["span"]) for k in ks]
    table = pd.DataFrame([r for r in rows if r is not None])
    return table.astype({"at_step": "Int64"}) if len(table) else table


def sweep_steps(spring, dt, span) -> int:
    """min(20 periods, span) in steps of dt, at least one."""
    return max(1, math.ceil(min(SWEEP_PERIODS * 2 * math.pi / spring.omega, span) / dt))


def sweep_row(engine, integrator, k, dt, span) -> dict | None:
    spring = Spring(stiffness=float(k))
    if engine.supports(spring.scene, integrator) is not None:
        return None
    steps = sweep_steps(spring, dt, span)
    row = {"engine": engine.name, "integrator": integrator, "k": float(k),
           "y": spring.omega * dt, "dt": dt, "steps": steps}
    try:
        sim = engine.build(spring.scene, dt, integrator, "")
        try:
            events, ratio = observe_run(sim, spring, steps)
            failure = sim.failure or ""
        finally:
            sim.close()
    except Exception as exc:  # a failure is a row, never a crash of the run
        return {**row, "failure": "error", "at_step": None, "energy_ratio": math.nan,
                "detail": f"{type(exc).__name__}: {exc}"}
    return {**row, **classify(events, ratio, failure)}


def observe_run(sim, spring, steps) -> tuple[dict, float]:
    """Step the whole run one step at a time; {event: first step} for "failure" (Sim.failure,
    ends the run), "nan_inf" (ends it), "energy_growth" (E >= F E0) and "reset" (a bitwise
    return to the initial state after energy_growth), and the last finite E / E0."""
    events, ratio = {}, 1.0
    for k in range(1, steps + 1):
        sim.step(1)
        o = sim.observe()
        x, v = np.asarray(o["x"]).reshape(-1), np.asarray(o["v"]).reshape(-1)
        if sim.failure:
            events["failure"] = k
            break
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(v))):
            events["nan_inf"] = k
            break
        if "energy_growth" in events and np.array_equal(x, spring.x0) and \
                np.array_equal(v, spring.v0):
            events["reset"] = k
            break
        ratio = float(spring.energy(x, v)[0]) / spring.e0
        if ratio >= ENERGY_FACTOR:
            events.setdefault("energy_growth", k)
    return events, ratio


def classify(events, ratio, failure="") -> dict:
    """The run's label, most telling first: silent_reset, engine_failure, nan_inf,
    energy_growth, artificial_damping, none (definitions in LEGEND)."""
    grew = events.get("energy_growth")
    before = f"energy >= {ENERGY_FACTOR:g} E0 from step {grew}" if grew else ""
    if "failure" in events:
        label = "silent_reset" if any(w in failure for w in RESET_WARNINGS) else \
            "engine_failure"
        return _label(label, events["failure"], math.nan, failure, before)
    if "reset" in events:
        return _label("silent_reset", events["reset"], ratio, "returned bitwise to the "
                      "initial state", before)
    if "nan_inf" in events:
        return _label("nan_inf", events["nan_inf"], math.nan, "non-finite state", before)
    if grew:
        return _label("energy_growth", grew, ratio, "", "")
    label = "artificial_damping" if ratio < DAMPED_FRACTION else "none"
    return _label(label, None, ratio, "", "")


def _label(failure, at, ratio, detail, before) -> dict:
    return {"failure": failure, "at_step": at, "energy_ratio": ratio,
            "detail": "; ".join(t for t in (detail, before) if t)}


