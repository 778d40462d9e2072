"""`refsim stress`'s stability limits: the options checked once, the probe case, the limit jobs
over engines x fixed-step integrators, the theory each is held to and the row of each measured
limit (what is measured and how: the package docstring, refsim.stress)."""
from __future__ import annotations

import math
import os
import shlex
import sys
from pathlib import Path

import pandas as pd

from refsim.store import results as store
from refsim.integrators import get_integrator
from refsim.integrators.spec import spec_name
from refsim.options import number
from refsim.stress.search import ENERGY_FACTOR, Y_MAX, Y_MIN, Criterion, find_limit, finite_time, \
    refsim_equivalent
from refsim.stress.spec import Probe
from refsim.stress.sweep import QUICK_SPAN, SWEEP_DT, SWEEP_K, SWEEP_SPAN

PERIODS, QUICK_PERIODS = 1000, 100
TOL, QUICK_TOL = 1e-5, 1e-3  # bisection tolerance, relative to max(1, y)
MAX_PERIODS = 100_000


# --------------------------------------------------------------------------------------------
# Options
# --------------------------------------------------------------------------------------------
def options(args) -> dict:
    """Validated options; ValueError naming the parameter and its valid range otherwise."""
    quick = bool(getattr(args, "quick", False))
    probe, is_default = _probe(getattr(args, "case", None), getattr(args, "variant", None))
    engines = _engines(getattr(args, "engine", None))
    spec = probe.spec
    periods = _periods(getattr(args, "periods", None),
                       spec.quick_periods if quick else spec.periods)
    return {"engines": engines, "integrators": _integrators(getattr(args, "integrator", None),
                                                            engines),
            "probe": probe, "sweep": is_default, "case": probe.case.name,
            "criterion": criterion(spec, periods), "tol": QUICK_TOL if quick else TOL,
            "dt": _dt(getattr(args, "dt", None)), "quick": quick,
            "span": QUICK_SPAN if quick else SWEEP_SPAN,
            "out": Path(getattr(args, "out", None) or store.DEFAULT_ROOT)}


def _probe(name, variant=None):
    """(Probe of the case, whether it is the default probe case); ValueError for a case that
    is not registered or declares no stability parameter, or a variant it does not have."""
    from refsim.registry import case_names, get_case
    from refsim.stress.search import probe_case
    default = probe_case()
    name = default.name if name is None else name
    if name == default.name and variant is None:
        return Probe(default), True
    known = case_names()
    if name not in known:
        raise ValueError(f"--case must be one of {known}, got {name!r}")
    case = get_case(name)
    if not _declares_stability(case):
        able = [n for n in known if _declares_stability(get_case(n))]
        raise ValueError(f"--case {name!r} declares no stability parameter (no "
                         f"`stability(p)`); cases that do: {able}")
    if variant is not None and variant not in case.variants:
        raise ValueError(f"--variant must be one of {list(case.variants)} for {name!r}, got "
                         f"{variant!r}")
    return Probe(case, variant=variant), False


def _declares_stability(case) -> bool:
    """Whether the case declares a stability parameter (`Case.stability` overridden)."""
    from refsim.case import Case
    return type(case).stability is not Case.stability


def criterion(spec, periods) -> Criterion:
    """The search criterion of a case's StabilitySpec at P periods."""
    if spec.oscillator and spec.energy_floor == 0.0:
        bound = ""  # the oscillator's own text: E < F E0
    elif spec.oscillator:
        bound = (f"the oscillation energy E - ({spec.energy_floor:.6g}) is < "
                 f"{ENERGY_FACTOR:g} times its initial value")
    else:
        floor = "E(0)" if spec.energy_floor is None else f"{spec.energy_floor:.6g}"
        bound = f"|E - {floor}| < {spec.energy_bound:.6g} J"
    return Criterion(periods, cycle=spec.cycle, name=spec.name, bound_text=bound)


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
    offered += [i for e in engines for g in get_engine(e).model_groups()
                for i in g.integrators or () if i not in offered]
    for name in names:
        if spec_name(name) not in offered:
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
    return number("--dt", value, 0.0, 1.0, unit="s")


def manifest(opts) -> dict:
    from refsim.registry import get_engine
    versions = {e: get_engine(e).version() for e in opts["engines"]}
    threads = os.environ.get("OMP_NUM_THREADS", "1")
    probe = opts["probe"].case
    env = store.environment(versions, {probe.name: probe.source_hash()},
                            int(threads) if threads.isdigit() else 1)
    return {"run_id": store.new_run_id(), "kind": "stress", "command": command(opts),
            "argv": sys.argv, "criterion": opts["criterion"].text(),
            "options": {"case": opts["case"], "variant": opts["probe"].variant,
                        "engines": opts["engines"],
                        "integrators": opts["integrators"],
                        "periods": opts["criterion"].periods, "tol": opts["tol"],
                        "sweep_dt": opts["dt"], "sweep_k": list(SWEEP_K),
                        "sweep_span_s": opts["span"], "quick": opts["quick"]},
            "status": "running", **env}


def command(opts) -> str:
    parts = ["refsim", "stress"] + ([] if opts["sweep"] else ["--case", opts["case"]])
    parts += ["--variant", opts["probe"].variant] if not opts["sweep"] else []
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
    """([(engine, formulation, integrator)] to search, ["engine integrator (why skipped)"]):
    fixed-step integrators the engine supports on the probe's scene, those of --integrator if
    given; every formulation where the spec asks for it (`StabilitySpec.formulations`)."""
    from refsim.registry import get_engine
    jobs, skipped = [], []
    for name in opts["engines"]:
        engine = get_engine(name)
        forms = engine.formulations(spring.scene) if spring.spec.formulations else ("",)
        offered = engine.offered_integrators(spring.scene)
        for integ in opts["integrators"] or offered:
            if spec_name(integ) not in offered:
                continue
            eq = refsim_equivalent(engine, integ)
            why = "adaptive" if eq and get_integrator(eq).adaptive else \
                engine.supports(spring.scene, integ)
            if why:
                skipped.append(f"{name} {integ} ({why})")
            else:
                jobs += [(engine, form, integ) for form in forms]
    return jobs, skipped


def limits_table(opts, spring) -> pd.DataFrame:
    jobs, skipped = limit_jobs(opts, spring)
    for line in skipped:
        print(f"stress: skipped {line}", file=sys.stderr)
    return pd.DataFrame([measure_limit(e, i, spring, opts, form) for e, form, i in jobs])


def limit_theory(engine, integrator, spring, crit, variant=""):
    """(refsim equivalent, theory, its reason, finite_time, resolution) of one job: the
    case's theory from the equivalent stepper and the Sim's settings; for an oscillator the
    criterion's exact landing (`finite_time`), else the spec's declared resolution."""
    sim = engine.build(spring.scene, float(spring.spec.to_dt(1.0)), integrator, variant)
    try:
        settings = sim.settings()
    finally:
        sim.close()
    # a Sim may declare the stepper it equals on this very scene (MuJoCo's discrete is
    # backward Euler on a spring, symplectic Euler on a hinge under gravity)
    declared = (settings.get("integrator") or {}) if isinstance(settings, dict) else {}
    eq = declared.get("stability_equivalent") if isinstance(declared, dict) else None
    eq = eq or refsim_equivalent(engine, integrator)
    stepper = get_integrator(eq) if eq else None
    th, why = spring.spec.theory(stepper, settings)
    if spring.spec.oscillator:
        ft, res = finite_time(stepper, th, crit) if stepper and not math.isnan(th) else \
            (math.nan, math.nan)
    else:
        ft, res = math.nan, spring.spec.resolution
    return eq, float(th), why, ft, res


def measure_limit(engine, integrator, spring, opts, variant="") -> dict:
    crit, tol = opts["criterion"], opts["tol"]
    row = {"engine": engine.name, "engine_variant": variant, "integrator": integrator,
           "measured": math.nan}
    try:
        eq, th, why, ft, res = limit_theory(engine, integrator, spring, crit, variant)
        row.update({"as": eq if eq and eq != integrator else "", "theory": th,
                    "theory_reason": why, "finite_time": ft, "resolution": res})
        found = find_limit(engine, integrator, spring, crit, tol, variant)
    except Exception as exc:  # a failure is a row, never a crash of the run
        return {"theory": math.nan, "finite_time": math.nan, "resolution": math.nan, **row,
                "agrees": False, "note": f"error: {type(exc).__name__}: {exc}"}
    row.update(measured=found.limit, agrees=agrees(found.limit, th, res, tol),
               evals=found.evaluations, batched=found.batched, seconds=round(found.seconds, 2))
    print(f"stress: {engine.name} {variant + ' ' if variant else ''}{integrator}: limit "
          f"{found.limit:.7g} ({found.seconds:.1f} s)", file=sys.stderr, flush=True)
    return {**row, "note": limit_note(found, th, res, spring.spec.oscillator)}


def agrees(measured, th, res, tol):
    if math.isnan(th):
        return None
    if math.isinf(th) or math.isinf(measured):
        return bool(measured == th)
    return bool(abs(measured - th) <= res + tol * max(1.0, th))


def limit_note(found, th, res, oscillator=True) -> str:
    notes = []
    if th == 0:
        notes.append("unstable at every y (finite-time criterion)")
    elif oscillator and 0 < th < math.inf and res > 1e-2:
        notes.append("criterion-limited (slow growth past the limit)")
    if math.isinf(found.limit):
        notes.append(f"stable to {Y_MAX:g}")
    elif found.limit == 0:
        notes.append(f"unstable down to {Y_MIN:g}")
    if found.fallback:
        notes.append("one Sim per y (array h fails)")
    return "; ".join(notes)
