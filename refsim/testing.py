"""Checks for pytest: run a case on an engine and assert each of the two verdicts by name.

    from refsim.testing import assert_consistent, assert_reaches_target
    def test_my_engine_pendulum():
        # behaves as symplectic Euler must at the case's reference dt
        assert_consistent("pendulum", "my_engine", "symplectic_euler")
        # and is accurate enough at a dt of your choice (the case's target, or your own)
        assert_reaches_target("pendulum", "my_engine", "symplectic_euler", dt=1e-4)

The whole suite for one engine (one test per case x variant x engine variant x integrator it
supports, at the case's reference dt):

    from refsim.testing import engine_suite
    test_my_engine = engine_suite(MyEngine)      # or a registered name, or an instance
"""
from __future__ import annotations

import math

from refsim.engine import Engine
from refsim.run.job import Job, run_job
from refsim.run.runner import expand


def accuracy(case, variant, engine, integrator, dt, engine_variant="", **params) -> dict:
    """Accuracy pass only (no timing); the results row, with the stacked observations under
    "trajectory"."""
    job = Job(case, variant, engine, engine_variant, integrator, float(dt),
              tuple(sorted(params.items())))
    return run_job(job, repeats=0, keep_trajectory=True)


def measured_order(case, variant, engine, integrator, dts, engine_variant="", **params):
    """(slope, points used, errors) of log err_max against log dt over `dts`."""
    from refsim.registry import get_case
    from refsim.run.metrics import convergence_order

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


def _run_ok(case, engine, integrator, variant, engine_variant, dt, params):
    from refsim.registry import get_case
    c = get_case(case)
    variant = variant or next(iter(c.variants))
    p = c.variant_params(variant, params)
    row = accuracy(case, variant, engine, integrator, dt or c.reference_dt(p), engine_variant,
                   **params)
    if row["status"] != "ok":
        raise AssertionError(f"{case}/{variant} on {engine} {integrator}: {row['status']} "
                             f"({row['reason']})")
    return row, f"{case}/{variant} on {engine} {integrator} at dt = {row['dt']:.3g} s"


def assert_consistent(case, engine, integrator, variant=None, engine_variant="", dt=None,
                      **params) -> dict:
    """Run `case` on `engine` at the case's reference dt (or `dt`) and assert that the row is
    consistent with the method `integrator` names (refsim.verdicts): an inconsistent,
    unresolved or method-less row fails, with the reason."""
    __tracebackhide__ = True  # pytest shows the failing test, not this helper
    row, label = _run_ok(case, engine, integrator, variant, engine_variant, dt, params)
    if row["consistency"] != "consistent":
        raise AssertionError(f"{label}: {row['consistency']}: "
                             f"{row['consistency_reason'] or row['tol_reason']} "
                             f"(bound: {row['tol_reason']})")
    return row


def assert_reaches_target(case, engine, integrator, variant=None, engine_variant="", dt=None,
                          target=None, **params) -> dict:
    """Run as `assert_consistent` and assert the error is within the case's accuracy target
    (or `target`, in the case's error column's units)."""
    __tracebackhide__ = True
    from refsim.registry import get_case
    row, label = _run_ok(case, engine, integrator, variant, engine_variant, dt, params)
    column = get_case(case).tolerance_column(get_case(case).variant_params(row["variant"],
                                                                           params))
    goal = row["target_error"] if target is None else float(target)
    if not row[column] <= goal:
        raise AssertionError(f"{label}: {column} {row[column]:.3g} does not reach the target "
                             f"{goal:.3g}")
    return row


def oscillator_stable(case, engine, integrator, y, energy_factor=1e4, periods=100,
                      engine_variant="", variant=None, **params) -> bool:
    """Stability criterion on an undamped oscillator case (one with `omega(p)`, e.g. the stiff
    spring) at y = omega dt: finite, and the energy after every step below energy_factor * E0
    over `periods` periods. (From rest, symplectic Euler's energy legitimately peaks at
    E0 / (1 - y/2): a factor of 10 would put its limit at y = 1.8, not 2.)"""
    import math

    import numpy as np

    from refsim.registry import get_case, get_engine
    case = get_case(case)
    p = case.variant_params(variant or next(iter(case.variants)), params)
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


# ---------------------------------------------------------------------------------------------
# The whole suite for one engine
# ---------------------------------------------------------------------------------------------
_FACTORIES: dict = {}  # engine name -> zero-argument callable, for classes and instances
_FACTORY_PREFIX = "engine_factory_"


def __getattr__(attr):
    """Registry targets "refsim.testing:engine_factory_<name>" resolve to `_FACTORIES[name]`
    (registry.get_engine calls the target with no arguments)."""
    name = attr[len(_FACTORY_PREFIX):] if attr.startswith(_FACTORY_PREFIX) else None
    if name in _FACTORIES:
        return _FACTORIES[name]
    raise AttributeError(f"module {__name__!r} has no attribute {attr!r}")


def resolve_engine(engine) -> str:
    """The registry name of `engine`: a registered name, an `Engine` subclass or an instance.

    Rules: a name must already be registered (`refsim.registry.register("engine", name,
    "module:Class")`). A
    class or instance is registered under its `name` attribute for the rest of the process (a
    class is instantiated with no arguments; an instance is used as given). A name registered
    by anything else (a built-in engine, a registry.register call) is never replaced: passing
    a different class under that name raises ValueError. Passing a class or instance again
    under a name this function registered replaces it (a module imported twice)."""
    from refsim.registry import engine_names, get_engine, register

    if isinstance(engine, str):
        get_engine(engine)  # ValueError naming the registered engines
        return engine
    if isinstance(engine, type) and issubclass(engine, Engine):
        cls, factory = engine, engine
    elif isinstance(engine, Engine):
        cls, factory = type(engine), (lambda: engine)
    else:
        raise ValueError(f"engine must be a registered engine name, an Engine subclass or an "
                         f"Engine instance, got {engine!r}")
    name = cls.name
    if name == Engine.name or not name or ":" in name:
        raise ValueError(f"engine {cls.__qualname__}.name must be set to a distinct name "
                         f"without ':', got {name!r}")
    if name in engine_names() and name not in _FACTORIES and type(get_engine(name)) is not cls:
        raise ValueError(f"engine name {name!r} is already registered to "
                         f"{type(get_engine(name)).__qualname__}: give "
                         f"{cls.__qualname__} a distinct `name`")
    if name in _FACTORIES or name not in engine_names():
        _FACTORIES[name] = factory
        register("engine", name, f"{__name__}:{_FACTORY_PREFIX}{name}")
    return name


def suite(engine, cases=None) -> list[Job]:
    """Every job `engine` runs in the tolerance suite: one per case x variant x engine variant
    x integrator, at the case's reference dt, expanded by `refsim.run.runner.expand` (so exactly
    the rows `refsim run` would make at that dt).

    Rules: `engine` as for `resolve_engine`; `cases` are case names (default: every case);
    the variants are those a plain `refsim run` covers (`case.default_variants`, else all);
    the integrators are the engine's own (`engine.integrators`) that `engine.supports(scene,
    integrator)` accepts. Scenes the engine does not support, and every scene when its
    package is not installed, give no job."""
    from refsim.registry import case_names, get_case

    name = resolve_engine(engine)
    cases = [cases] if isinstance(cases, str) else list(cases or case_names())
    jobs = []
    for cname in cases:
        case = get_case(cname)
        for variant in case.default_variants or case.variants:
            dt = case.reference_dt(case.variant_params(variant))
            jobs += [j for j in expand([cname], [name], dts=[dt], variants=[variant])
                     if math.isfinite(j.dt)]
    return jobs


def job_id(job: Job) -> str:
    """A readable test id: case/variant[-engine variant]-integrator."""
    ev = f"-{job.engine_variant}" if job.engine_variant else ""
    return f"{job.case}/{job.variant}{ev}-{job.integrator}"


def check(job: Job) -> dict:
    """Assert one suite job: it runs to the end, and is consistent with the method it names
    (AssertionError naming the error, the bound and its reason otherwise). A row with no
    verdict to give (unresolved at that dt, or the engine's own scheme: no method
    reference) is held to running to the end only. Returns the results row."""
    __tracebackhide__ = True
    row, label = _run_ok(job.case, job.engine, job.integrator, job.variant,
                         job.engine_variant, job.dt, dict(job.params))
    if row["consistency"] == "inconsistent":
        raise AssertionError(f"{label}: inconsistent with its method: "
                             f"{row['consistency_reason']} (bound: {row['tol_reason']})")
    return row


def suite_params(engine, cases=None) -> list:
    """`suite` as pytest params with readable ids; one skipped param saying why when the
    engine runs none of the cases (not installed, or no supported scene)."""
    import pytest

    jobs = suite(engine, cases)
    if jobs:
        return [pytest.param(j, id=job_id(j)) for j in jobs]
    name = resolve_engine(engine)
    from refsim.registry import get_engine
    why = ("is not installed" if not get_engine(name).available()
           else f"supports none of the scenes of {cases or 'any case'}")
    return [pytest.param(None, id="no-jobs", marks=pytest.mark.skip(reason=f"{name} {why}"))]


def engine_suite(engine, cases=None):
    """A pytest test function parametrised over `suite(engine, cases)`:

        test_my_engine = engine_suite("my_engine")     # or engine_suite(MyEngine)

    Works with plain pytest (no plugin needed); the `refsim_engine` marker of
    refsim.pytest_plugin is the same suite for a test function written by hand."""
    import pytest

    @pytest.mark.parametrize("refsim_job", suite_params(engine, cases))
    def test_engine_suite(refsim_job):
        check(refsim_job)

    return test_engine_suite
