"""The runner: failures are rows, divergence is detected, the store keeps every row."""
import numpy as np
import pytest

from refsim import registry
from refsim.engine import Engine, ModelGroup
from refsim.run.job import Job, run_job
from refsim.run.runner import expand, run_matrix
from refsim.store.results import RunStore, load_results


def _explode(engine, scene, dt, integrator, formulation):
    raise RuntimeError("solver exploded\nsecond line")


class BrokenEngine(Engine):
    name = "broken"
    dims = (2, 3)
    integrators = ("symplectic_euler",)
    groups = (ModelGroup(name="particles", claims=lambda scene: True, parts=None,
                         features=frozenset({"gravity", "springs", "joints", "drag"}),
                         build=_explode),)


class MissingEngine(BrokenEngine):
    name = "missing"
    package = "no_such_engine_package"


@pytest.fixture
def fake_engines():
    registry.register("engine", "broken", f"{__name__}:BrokenEngine")
    registry.register("engine", "missing", f"{__name__}:MissingEngine")
    yield
    for name in ("broken", "missing"):
        registry.unregister("engine", name)


def test_failure_is_a_row_not_a_crash(fake_engines, tmp_path):
    jobs = expand(["free_fall"], ["broken", "missing", "refsim"], ["symplectic_euler"],
                  [0.01], variants=["default"])
    store = RunStore.create(tmp_path, {"run_id": "r1"})
    table = run_matrix(jobs, store, repeats=1)
    status = dict(zip(table["engine"], table["status"]))
    assert status == {"broken": "failed", "missing": "unavailable", "refsim": "ok"}
    broken = table[table["engine"] == "broken"].iloc[0]
    assert broken["reason"] == "RuntimeError: solver exploded"
    assert len(load_results(tmp_path / "r1")) == 3


class PeerEngine(BrokenEngine):
    name = "peer"
    peer = True


def test_a_peer_engine_runs_only_where_named():
    registry.register("engine", "peer", f"{__name__}:PeerEngine")
    try:
        assert "peer" not in {j.engine for j in expand(["free_fall"], quick=True)}
        named = expand(["free_fall"], ["peer"], ["symplectic_euler"], quick=True)
        assert named and {j.engine for j in named} == {"peer"}
    finally:
        registry.unregister("engine", "peer")


def test_divergence_is_detected_early():
    # explicit Euler on the undamped spring at w dt = 0.5: energy x 1.25 per step
    row = run_job(Job("stiff_spring", "default", "refsim", "", "explicit_euler", 5e-3),
                  repeats=0)
    assert row["status"] == "diverged" and "energy grew past" in row["reason"]
    assert 0 < row["diverged_t"] < row["t_end"]


def test_unsupported_scene_has_a_reason():
    row = run_job(Job("pendulum", "default", "refsim", "", "rk4", 1e-3), repeats=0)
    assert row["status"] == "failed" and "formulation must be one of" in row["reason"]


def test_timing_pass_is_separate_and_repeated():
    # a budget far above the run time: at least two timed runs, more only while unsettled
    row = run_job(Job("pendulum", "default", "refsim", "generalized", "rk4", 1e-3), repeats=3,
                  budget_s=60.0)
    assert row["status"] == "ok" and row["repeats"] in (2, 3)
    assert row["step_s"] <= row["step_s_median"]
    assert row["us_per_step"] == pytest.approx(row["step_s"] / row["steps"] * 1e6)
    assert np.isfinite(row["setup_s"]) and row["setup_s"] >= 0
    assert f"min of {row['repeats']}, median " in row["timing"]


class _ScriptedClock:
    """perf_counter for refsim.run.job: each timed `step(n)` call of a _ScriptedSim takes the
    next scripted duration (n > 1) or 1 ms (a 1-step call); nothing else takes time."""

    def __init__(self, durations):
        self.now, self.durations = 0.0, list(durations)

    def perf_counter(self):
        return self.now


class _ScriptedSim:
    compile_s = 0.0

    def __init__(self, clock):
        self.clock = clock

    def step(self, n):
        self.clock.now += self.clock.durations.pop(0) if n > 1 else 1e-3

    def close(self):
        pass


class _ScriptedEngine:
    def __init__(self, clock):
        self.clock = clock

    def build(self, scene, dt, integrator, variant):
        return _ScriptedSim(self.clock)


@pytest.mark.parametrize("durations, repeats, budget, expected, words", [
    # two runs 2 % apart: the figure is stable, no third run
    ([0.100, 0.102], 5, 0.5, 2, "median 1 % above it,"),
    # the second 20 % slower, the third settles it (median 0.101 within 5 % of 0.1)
    ([0.100, 0.120, 0.101], 5, 0.5, 3, "median 1 % above it,"),
    # never settles: runs until the budget of timed runs is spent, and says so
    ([0.100, 0.130, 0.160, 0.190, 0.220, 0.250], 9, 0.5, 4, "(unsettled)"),
    # never settles and the most repeats come first
    ([0.100, 0.130, 0.160, 0.190], 3, 60.0, 3, "(unsettled)"),
    # one repeat asked: one run, no spread to state
    ([0.100], 1, 0.5, 1, "min of 1, first"),
])
def test_timing_repeats_stop_when_the_median_is_within_the_spread(
        monkeypatch, durations, repeats, budget, expected, words):
    """The stopping rule with a scripted clock (no machine noise): at least two timed runs,
    more while the median is over TIMING_SPREAD (5 %) above the min and the timed runs have
    taken under the budget; the probe that sized N' (its N the final one) is the first run."""
    import refsim.run.timing as job_module
    clock = _ScriptedClock(durations)
    monkeypatch.setattr(job_module, "time", clock)
    job = Job("free_fall", "default", "x", "", "rk4", 1e-3)
    row = job_module.timing_pass(_ScriptedEngine(clock), None, job, steps=2000, timed=1000,
                                  repeats=repeats, budget_s=budget)
    assert row["repeats"] == expected and words in row["timing"], row["timing"]
    assert row["step_s"] == pytest.approx(2 * min(durations[:expected]))
    assert row["timed_steps"] == 1000 and row["call_us"] == pytest.approx(1e3)


def test_bound_above_the_motion_is_unresolved_never_within_tolerance():
    # implicit Euler at w0 dt = 0.2 damps the spring to 5 % of its amplitude in 5 periods: its
    # exact discrete error is 96 % of the amplitude, a bound that says nothing
    row = run_job(Job("stiff_spring", "default", "refsim", "", "implicit_euler", 0.002),
                  repeats=0)
    from refsim.registry import get_case
    scale = get_case("stiff_spring").motion_scale(get_case("stiff_spring").variant_params(
        "default"))
    assert row["status"] == "ok" and row["tolerance"] >= 0.5 * scale
    assert row["consistency"] == "unresolved"
    assert "unresolved" in row["tol_reason"] and "unresolved" in row["consistency_reason"]


def test_resolved_row_states_its_round_off_term():
    row = run_job(Job("stiff_spring", "default", "refsim", "", "rk4", 5e-4), repeats=0)
    assert row["consistency"] == "consistent"
    steps = row["steps"]
    bound = steps * np.finfo(float).eps * 0.5 * (1.0 + 2 * 0.1)  # n eps (L0 + 2A) / 2
    assert f"round-off n eps S = {bound:.3g} (n = {steps} steps" in row["tol_reason"]


def test_job_with_dt_longer_than_the_run_is_a_failed_row_saying_so():
    row = run_job(Job("free_fall", "default", "refsim", "", "rk4", 10.0), repeats=0)
    assert row["status"] == "failed"
    assert row["reason"] == ("ValueError: dt = 10 s is longer than the run of free_fall/default "
                             "(t_end = 2 s): dt must be in (0, 2] s")


@pytest.mark.parametrize("kwargs,message", [
    ({"dts": [10.0]}, "dt = 10 s is longer than the run of free_fall/default (t_end = 2 s): dt "
                      "must be in (0, 2] s"),
    ({"dts": [1e-300]}, "dt = 1e-300 s gives 2e+300 steps for free_fall/default: dt must be in "
                        "[2e-08, 2] s, at most --max-steps 1e+08 steps"),
    ({"dts": [1e-4], "max_steps": 1000}, "dt = 0.0001 s gives 2e+04 steps for free_fall/default: "
                                         "dt must be in [0.002, 2] s, at most --max-steps 1000"),
    ({"integrators": ["rk2:"]}, "integrator 'rk2:': a parameter must follow ':' (alpha in "
                                "(0, 1]"),
    ({"integrators": ["dopri5_adaptive:"]}, "integrator 'dopri5_adaptive:': a parameter must "
                                            "follow ':' (rtol > 0"),
    ({"integrators": ["rk4:"]}, "integrator 'rk4:': a parameter must follow ':' (this "
                                "integrator takes none)"),
])
def test_expand_refuses_bad_steps_and_empty_integrator_parameters(kwargs, message):
    with pytest.raises(ValueError) as caught:
        expand(["free_fall"], ["refsim"], variants=["default"], **kwargs)
    assert str(caught.value).startswith(message), str(caught.value)


def test_max_steps_bound_is_inclusive_and_overridable():
    jobs = expand(["free_fall"], ["refsim"], ["rk4"], [1e-3], variants=["default"],
                  max_steps=2000)
    assert [j.dt for j in jobs] == [1e-3]


def test_summary_counts_rows_by_verdict():
    import io
    import pandas as pd
    from refsim.run.summary import print_summary, verdict_counts
    base = {"case": "stiff_spring", "variant": "default", "engine": "refsim",
            "engine_variant": "", "dt": 0.002, "energy_drift": 0.1, "us_per_step": 1.0,
            "order": np.nan, "reason": ""}
    table = pd.DataFrame([
        {**base, "integrator": "implicit_euler", "status": "ok", "err_max": 0.09,
         "consistency": "unresolved", "reaches_target": False},
        {**base, "integrator": "rk4", "status": "ok", "err_max": 1e-6,
         "consistency": "consistent", "reaches_target": True},
        {**base, "integrator": "heun", "status": "ok", "err_max": 1e-2,
         "consistency": "inconsistent", "reaches_target": False},
        {**base, "integrator": "implicitfast", "status": "ok", "err_max": 1e-3,
         "consistency": "no method reference", "reaches_target": False},
        {**base, "integrator": "explicit_euler", "status": "diverged", "err_max": np.nan,
         "consistency": "", "reaches_target": False}])
    assert verdict_counts(table) == {"consistent": 1, "inconsistent": 1, "unresolved": 1,
                                     "no method reference": 1, "reach the target": 1}
    out = io.StringIO()
    print_summary(table, out)
    text = out.getvalue()
    assert "9.0e-02? " in text and "1.0e-02! " in text and "1.0e-06* " in text
    assert "1.0e-03~ " in text
    assert text.strip().splitlines()[-1] == (
        "5 rows: ok 4 (consistent 1, inconsistent 1, unresolved 1, no method reference 1, "
        "reach the target 1), diverged 1")


def test_stored_run_before_the_two_verdicts_reads_with_them():
    """An old table's within_tol/unresolved become consistency, saying the old rule."""
    import pandas as pd
    from refsim.verdicts import OLD_RULE, upgrade_table
    old = pd.DataFrame({"status": ["ok", "ok", "ok", "diverged"],
                        "within_tol": [True, "False", False, False],
                        "unresolved": [False, False, "True", False]})
    new = upgrade_table(old)
    assert list(new["consistency"]) == ["consistent", "inconsistent", "unresolved", ""]
    assert list(new["consistency_reason"]) == [OLD_RULE] * 3 + [""]


def test_pendulum_bound_counts_an_engines_point_inertia():
    # a bob of inertia I on a rod: (m L^2 + I) theta'' slows w0 by I / (2 m L^2); MuJoCo's
    # 1e-12 kg m^2 gives 1.4e-11 rad at any dt (its RK4 floor on the default swing)
    from refsim.registry import get_case
    case = get_case("pendulum")
    p = case.variant_params("default")
    plain, _ = case.tolerance(p, "rk4", 4, 1e-4, "", {})
    with_inertia, why = case.tolerance(p, "rk4", 4, 1e-4, "", {"point_inertia": 1e-12})
    # I / (2 m L^2) with m = 0.5 kg, L = 1 m: 1e-12, times w0 t = sqrt(9.81) x 10 s
    assert with_inertia - plain == pytest.approx(1.0 * np.sqrt(9.81) * 10.0 * 1e-12)
    assert "bob's own inertia I = 1e-12 kg m^2" in why


def test_alternative_formulations_run_on_the_cases_declared_variants_only():
    """The pendulum compares its maximal-coordinate formulations on the default swing; the
    large swing runs them when named or with --full."""
    from refsim.run.runner import expand
    plain = expand(cases=["pendulum"], engines=["refsim"])
    forms = {(j.variant, j.engine_variant) for j in plain}
    assert ("default", "kkt") in forms and ("default", "penalty") in forms
    assert {v for v, f in forms if f in ("kkt", "penalty")} == {"default"}
    named = expand(cases=["pendulum"], engines=["refsim"], variants=["large_amplitude"])
    assert {j.engine_variant for j in named} == {"generalized", "kkt", "penalty"}
    full = expand(cases=["pendulum"], engines=["refsim"], full=True)
    assert ("large_amplitude", "kkt") in {(j.variant, j.engine_variant) for j in full}


def test_a_decaying_mode_is_never_diverged():
    """heat_mode 3d, k = 15 at r = 0.165: FTCS's factor |G| = 0.961 decays the mode, while the
    semi-discrete decay is 46.6x faster a step; the run is bounded, so it is ok (its error the
    size of the mode: unresolved), never diverged."""
    from refsim.registry import get_case
    case = get_case("heat_mode")
    params = (("decay_times", 100.0), ("k", 15))
    p = case.variant_params("3d", dict(params))
    dt = case.dt_of(p, 0.165)
    assert abs(case.factor(p, "explicit_euler", dt)) == pytest.approx(0.961, abs=1e-3)
    row = run_job(Job("heat_mode", "3d", "refsim", "", "explicit_euler", dt, params),
                  repeats=0)
    assert row["status"] == "ok" and row["consistency"] == "unresolved"


class _Stub:
    """A sim whose solver gives up at its third step with a finite, bounded state."""

    def __init__(self, message):
        self.failure, self.k, self.message = None, 0, message

    def observe(self):
        return {"t": 0.01 * self.k, "x": np.zeros((1, 3)), "v": np.zeros((1, 3))}

    def step(self, n):
        self.k += n
        if self.k >= 3:
            self.failure = self.message


@pytest.mark.parametrize("message", ["implicit_euler: Newton did not converge in 50 "
                                     "iterations at t=0.03", "contact list full"])
def test_solver_failure_with_a_bounded_state_is_failed_with_one_time(message):
    from refsim.run.job import EngineClock, _accuracy_pass
    from refsim.registry import get_case
    case = get_case("free_fall")
    p = case.variant_params("default")
    _, stop, _ = _accuracy_pass(case, p, _Stub(message), 10, 1, EngineClock())
    status, why, t = stop
    assert status == "failed" and why.startswith(message.split(" at t=")[0])
    assert why.count("t=") == 1 and t == pytest.approx(0.03)


def test_judge_reads_the_bound_the_initial_state_and_half_the_motion():
    from refsim.verdicts import judge
    ok = judge(1e-6, 2e-6, "why", 1.0, 0.0, 1e-12)
    assert ok["consistency"] == "consistent" and ok["tolerance"] == 2e-6
    above = judge(3e-6, 2e-6, "why", 1.0, 0.0, 1e-12)
    assert above["consistency"] == "inconsistent" and "1.5x" in above["consistency_reason"]
    late = judge(1e-6, 2e-6, "why", 1.0, 1e-4, 1e-12)  # one step ahead at t = 0
    assert late["consistency"] == "inconsistent" and "t = 0" in late["consistency_reason"]
    unknown_start = judge(1e-6, 2e-6, "why", 1.0, float("nan"), 1e-12)
    assert unknown_start["consistency"] == "consistent"
    assert judge(0.1, 0.5, "why", 1.0, 0.0, 1e-12)["consistency"] == "unresolved"


def test_equilibrium_case_is_not_judged_on_its_start():
    """hanging_chain's reference is the end state: the start is far from it by design."""
    from refsim.registry import get_case
    case = get_case("hanging_chain")
    p = case.variant_params("default")
    row = run_job(Job("hanging_chain", "default", "refsim", "", "symplectic_euler_dk",
                      case.reference_dt(p)), repeats=0)
    assert row["err_initial"] > 1e-3 and row["consistency"] == "consistent"


def test_a_lower_declared_order_is_inconsistent_with_the_method_named():
    from refsim.verdicts import declared_reason
    assert "declares order 2" in declared_reason(2.0, 4.0)
    assert declared_reason(4.0, 4.0) is None and declared_reason(float("nan"), 4.0) is None
    assert declared_reason(5.0, 4.0) is None  # a higher claim is judged by its errors


def test_source_hash_covers_the_case_packages_helper_modules():
    """An edit to a helper module a case imports from its own package (dzhanibekov's bounds in
    cases/rigid/_bounds.py) must change the case's hash: compare never reads it silently."""
    import inspect
    from refsim.case import _package_imports
    from refsim.registry import get_case
    module = inspect.getmodule(type(get_case("dzhanibekov")))
    assert "refsim_cases.rigid._bounds" in {m.__name__ for m in _package_imports(module)}


class _LaunchSim:
    """One call costs a fixed 2 ms launch, each step 1 us (a kernel launch per call)."""

    compile_s = 0.0

    def step(self, n):
        import time
        time.sleep(2e-3 + 1e-6 * n)

    def close(self):
        pass


class _LaunchEngine:
    def build(self, scene, dt, integrator, variant):
        return _LaunchSim()


def test_timing_stretch_is_not_sized_by_the_observation_calls():
    """The accuracy pass's per-observation calls made it look long (N' = 10 of 1000 steps):
    one probe call shows the whole run fits the timing budget, so the whole run is timed.
    Three repeats, not one: the call-dominated test compares the 1-step call with the best
    whole run, and one scheduler delay of a few ms in a single timed run made the 3 ms run
    look long enough that the 2 ms call was under half of it (it failed so once, in a
    fresh-clone suite on 2026-11-27)."""
    from refsim.run.timing import timing_pass as _timing_pass
    job = Job("free_fall", "default", "x", "", "rk4", 1e-3)
    row = _timing_pass(_LaunchEngine(), None, job, steps=1000, timed=10, repeats=3,
                       budget_s=1.0)
    assert row["timed_steps"] == 1000 and row["timing"].startswith("fresh models, min of ")
    assert row["us_per_step"] == pytest.approx(row["step_s"] / 1000 * 1e6)
    # the 2 ms launch is stated apart, and the run is said to be call-dominated (2 of 3 ms)
    assert row["call_us"] >= 2e3 and "call-dominated" in row["timing"]  # sleep never returns early


def test_energy_behaviour_reads_drift_not_size():
    """A bounded oscillating energy error passes whatever its size; a drift of twice its
    amplitude over the run does not; a run shorter than four periods is not judged."""
    from refsim.verdicts import energy_reason
    t = np.linspace(0.0, 10.0, 401)
    bounded = 1.0 + 0.3 * np.sin(2 * np.pi * t) ** 2  # period 0.5 s, a large error
    assert energy_reason(t, bounded, 1.0, 1.0, 1000) is None
    drifting = bounded - 0.07 * t  # 0.7 over the run, about twice the oscillation's 0.3
    why = energy_reason(t, drifting, 1.0, 1.0, 1000)
    assert why is not None and "first quarter" in why
    assert energy_reason(t, drifting, 1.0, 3.0, 1000) is None  # a quarter < the period
    # round-off: eps-sized drifts over many steps are not judged as a drift
    assert energy_reason(t, 1.0 + 1e-13 * t, 1.0, 1.0, 10**6) is None


def test_energy_behaviour_is_not_read_from_aliased_samples():
    """4 observations per period (400 samples of a 100-period run) alias the oscillation's
    maxima: not judged, whatever the windows' maxima say."""
    from refsim.verdicts import energy_reason
    t = np.linspace(0.0, 100.0, 401)
    aliased = 1.0 + 0.3 * np.sin(2 * np.pi * 1.01 * t) ** 2
    assert energy_reason(t, aliased - 0.01 * t, 1.0, 1.0, 10**4) is None


def test_stored_runs_carry_their_format_and_a_newer_one_is_refused(tmp_path):
    """A new run's manifest says format FORMAT; an unstamped run is format 1 and opens; a
    format this refsim does not know is refused with a one-line reason."""
    import json

    from refsim.store.results import FORMAT, RunStore, run_format
    st = RunStore.create(tmp_path, {"run_id": "r1"})
    assert st.manifest["format"] == FORMAT and run_format(st.dir) == FORMAT
    old = tmp_path / "old"
    old.mkdir()
    (old / "manifest.json").write_text(json.dumps({"run_id": "old"}))
    assert run_format(old) == 1
    (old / "manifest.json").write_text(json.dumps({"run_id": "old", "format": FORMAT + 1}))
    with pytest.raises(ValueError, match="run format must be"):
        run_format(old)


def test_an_overflowing_order_bound_is_infinite_and_silent():
    """Past exp's range the non-symplectic bound rules nothing out: inf, with no numpy warning
    on the console (refsim run --case pendulum --dt 10 printed four)."""
    import warnings

    from refsim.case import order_tolerance
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert order_tolerance(1.0, 100.0, 10.0, 2) == float("inf")
        assert order_tolerance(2.0, 1.0, 0.1, 2) == 2.0 * np.expm1(1.0 * 0.1 ** 2)  # same ops


def test_an_engines_warnings_go_into_the_row_not_the_terminal(monkeypatch, recwarn):
    """Warnings raised while a job runs (an engine's own, numpy's on a diverging state) are
    the row's `warnings`, each distinct one once with its count; none reaches the caller."""
    import warnings
    import refsim.run.job as job_module

    def warn_twice(job, row, *args):
        warnings.warn("contact buffer full", UserWarning)
        warnings.warn("contact buffer full", UserWarning)
        np.float64(1e308) * 10  # numpy's overflow RuntimeWarning
        row.update(status="ok")
    monkeypatch.setattr(job_module, "_run_job", warn_twice)
    row = run_job(Job("free_fall", "default", "refsim", "", "rk4", 1e-3), repeats=0)
    assert row["status"] == "ok"
    assert row["warnings"] == ("UserWarning: contact buffer full (x2); "
                               "RuntimeWarning: overflow encountered in scalar multiply")
    assert len(recwarn) == 0
