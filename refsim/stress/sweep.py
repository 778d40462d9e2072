"""The stiffness sweep and failure taxonomy of `refsim stress` on the probe case (the
undamped spring): sections 2 and 3 of refsim.stress.limits's docstring."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from refsim.integrators.spec import spec_name
from refsim.stress.search import ENERGY_FACTOR
from refsim.stress.spec import Probe as Spring

SWEEP_K = tuple(10.0 ** np.arange(1, 9))
SWEEP_DT, SWEEP_PERIODS, SWEEP_SPAN, QUICK_SPAN = 1e-3, 20, 2.0, 0.5
SWEEP_NAMED = ("symplectic_euler", "explicit_euler", "rk4", "implicit_euler", "discrete")
DAMPED_FRACTION = 0.01
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


# --------------------------------------------------------------------------------------------
# 2. Stiffness sweep
# --------------------------------------------------------------------------------------------
def sweep_integrators(engine, requested=None):
    """Default (symplectic Euler where offered, else the first) and the named ones offered."""
    if requested:
        return [i for i in requested if spec_name(i) in engine.integrators]
    default = "symplectic_euler" if "symplectic_euler" in engine.integrators \
        else engine.integrators[0]
    return [default] + [i for i in SWEEP_NAMED if i in engine.integrators and i != default]


def sweep_table(opts, ks=SWEEP_K) -> pd.DataFrame:
    from refsim.registry import get_engine
    rows = []
    for name in opts["engines"]:
        engine = get_engine(name)
        for integ in sweep_integrators(engine, opts["integrators"]):
            rows += [sweep_point(engine, integ, k, opts["dt"], opts["span"]) for k in ks]
    table = pd.DataFrame([r for r in rows if r is not None])
    return table.astype({"at_step": "Int64"}) if len(table) else table


def sweep_steps(spring, dt, span) -> int:
    """min(20 periods, span) in steps of dt, at least one."""
    return max(1, math.ceil(min(SWEEP_PERIODS * 2 * math.pi / spring.omega, span) / dt))


def sweep_point(engine, integrator, k, dt, span) -> dict | None:
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


