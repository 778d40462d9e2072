"""The runner: failures are rows, divergence is detected, the store keeps every row."""
import numpy as np
import pytest

from refsim import registry
from refsim.engine import Engine
from refsim.runner import Job, expand, run_job, run_matrix
from refsim.store import RunStore, load_results


class BrokenEngine(Engine):
    name = "broken"
    capabilities = frozenset({"gravity", "springs", "joints", "drag"})
    dims = (2, 3)
    integrators = ("symplectic_euler",)

    def build(self, scene, dt, integrator, variant=""):
        raise RuntimeError("solver exploded\nsecond line")


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


def test_divergence_is_detected_early():
    # explicit Euler on the undamped spring at w dt = 0.5: energy x 1.25 per step
    row = run_job(Job("stiff_spring", "default", "refsim", "", "explicit_euler", 5e-3),
                  repeats=0)
    assert row["status"] == "diverged" and "energy beyond" in row["reason"]
    assert 0 < row["diverged_t"] < row["t_end"]


def test_unsupported_scene_has_a_reason():
    row = run_job(Job("pendulum", "default", "refsim", "", "rk4", 1e-3), repeats=0)
    assert row["status"] == "failed" and "variant must be one of" in row["reason"]


def test_timing_pass_is_separate_and_repeated():
    # a budget far above the run time: three repeats even on a loaded machine
    row = run_job(Job("pendulum", "default", "refsim", "generalized", "rk4", 1e-3), repeats=3,
                  budget_s=60.0)
    assert row["status"] == "ok" and row["repeats"] == 3
    assert row["step_s"] <= row["step_s_median"]
    assert row["us_per_step"] == pytest.approx(row["step_s"] / row["steps"] * 1e6)
    assert np.isfinite(row["setup_s"]) and row["setup_s"] >= 0


def test_bound_above_the_motion_is_unresolved_never_within_tolerance():
    # implicit Euler at w0 dt = 0.2 damps the spring to 5 % of its amplitude in 5 periods: the
    # error stays below the amplitude, yet the derived bound (53 A) says nothing about it
    row = run_job(Job("stiff_spring", "default", "refsim", "", "implicit_euler", 0.002),
                  repeats=0)
    assert row["status"] == "ok" and row["err_max"] < 0.1 == row["tolerance"]
    assert row["unresolved"] is True and row["within_tol"] is False
    assert "unresolved" in row["tol_reason"]


def test_resolved_row_states_its_round_off_term():
    row = run_job(Job("stiff_spring", "default", "refsim", "", "rk4", 5e-4), repeats=0)
    assert row["unresolved"] is False and row["within_tol"] is True
    steps = row["steps"]
    bound = steps * np.finfo(float).eps * 0.5 * (1.0 + 2 * 0.1)  # n eps (L0 + 2A) / 2
    assert f"round-off n eps S = {bound:.3g} (n = {steps} steps" in row["tol_reason"]


def test_job_with_dt_longer_than_the_run_is_a_failed_row_saying_so():
    row = run_job(Job("free_fall", "default", "refsim", "", "rk4", 10.0), repeats=0)
    assert row["status"] == "failed"
    assert row["reason"] == ("ValueError: dt = 10 s is longer than the run (t_end = 2 s): dt "
                             "must be in (0, 2] s")


@pytest.mark.parametrize("kwargs,message", [
    ({"dts": [10.0]}, "--dt 10 is longer than the run of free_fall/default (t_end = 2 s): dt "
                      "must be in (0, 2] s"),
    ({"dts": [1e-300]}, "--dt 1e-300 gives 2e+300 steps for free_fall/default: dt must be in "
                        "[2e-08, 2] s, at most --max-steps 1e+08 steps"),
    ({"dts": [1e-4], "max_steps": 1000}, "--dt 0.0001 gives 2e+04 steps for free_fall/default: "
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


def test_summary_counts_unresolved_rows_apart():
    import io
    import pandas as pd
    from refsim.summary import print_summary, verdict_counts
    base = {"case": "stiff_spring", "variant": "default", "engine": "refsim",
            "engine_variant": "", "dt": 0.002, "energy_drift": 0.1, "us_per_step": 1.0,
            "order": np.nan, "reason": ""}
    table = pd.DataFrame([
        {**base, "integrator": "implicit_euler", "status": "ok", "err_max": 0.09,
         "within_tol": False, "unresolved": True},
        {**base, "integrator": "rk4", "status": "ok", "err_max": 1e-6, "within_tol": True,
         "unresolved": False},
        {**base, "integrator": "heun", "status": "ok", "err_max": 1e-2, "within_tol": False,
         "unresolved": False},
        {**base, "integrator": "explicit_euler", "status": "diverged", "err_max": np.nan,
         "within_tol": False, "unresolved": False}])
    assert verdict_counts(table) == {"within tolerance": 1, "above tolerance": 1,
                                     "unresolved": 1}
    out = io.StringIO()
    print_summary(table, out)
    text = out.getvalue()
    assert "9.0e-02?" in text and "1.0e-02!" in text and "1.0e-06 " in text
    assert text.strip().splitlines()[-1] == ("4 rows: ok 3 (within tolerance 1, above "
                                             "tolerance 1, unresolved 1), diverged 1")


def test_pendulum_bound_counts_an_engines_point_inertia():
    # a bob of inertia I on a rod: (m L^2 + I) theta'' slows w0 by I / (2 m L^2); MuJoCo's
    # 1e-12 kg m^2 gives 1.4e-11 rad at any dt (its RK4 floor on the default swing)
    from refsim.registry import get_case
    case = get_case("pendulum")
    p = case.variant_params("default")
    plain, _ = case.tolerance(p, "rk4", 4, 1e-4, "", {})
    with_inertia, why = case.tolerance(p, "rk4", 4, 1e-4, "", {"point_inertia": 1e-12})
    assert with_inertia - plain == pytest.approx(1.0 * np.sqrt(9.81) * 10.0 * 0.5e-12)
    assert "bob's own inertia I = 1e-12 kg m^2" in why


def test_alternative_formulations_run_on_the_cases_declared_variants_only():
    """The pendulum compares its maximal-coordinate formulations on the default swing; the
    large swing runs them when named or with --full."""
    from refsim.runner import expand
    plain = expand(cases=["pendulum"], engines=["refsim"])
    forms = {(j.variant, j.engine_variant) for j in plain}
    assert ("default", "kkt") in forms and ("default", "penalty") in forms
    assert {v for v, f in forms if f in ("kkt", "penalty")} == {"default"}
    named = expand(cases=["pendulum"], engines=["refsim"], variants=["large_amplitude"])
    assert {j.engine_variant for j in named} == {"generalized", "kkt", "penalty"}
    full = expand(cases=["pendulum"], engines=["refsim"], full=True)
    assert ("large_amplitude", "kkt") in {(j.variant, j.engine_variant) for j in full}
