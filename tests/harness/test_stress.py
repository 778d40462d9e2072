"""`refsim stress`: measured stability limits against theory, the failure taxonomy, bad input.

Theory, not snapshots: each measured limit must sit within the bisection tolerance of the
limit the stated criterion predicts from the method's exact step map (`finite_time`), and
within that prediction's resolution of the asymptotic limit (2, 2 sqrt 2, 0.99719, ...).
"""
import argparse
import contextlib
import io
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from refsim.registry import get_engine
from refsim.cli import stress as stress_cli
from refsim.stress import limits as stress
from refsim.stress import sweep as stress_sweep
from refsim.stress import store as stress_store
from refsim.report.compare import compare_runs
from refsim.report.build import write_report
from refsim.store.results import KEY, load_definitions_list, load_results
from refsim.store.runs import open_run
from refsim.integrators import get_integrator
from refsim.stress.search import (Criterion, batch_evaluator, batch_stepper, find_limit,
                                  finite_time, sim_evaluator, theory)
from refsim.stress.spec import Probe as Spring

THEORY = {"symplectic_euler": 2.0, "symplectic_euler_dk": 2.0, "velocity_verlet": 2.0,
          "stormer_verlet": 2.0, "leapfrog": 2.0, "rk4": 2 * math.sqrt(2),
          "dopri5": 0.99719, "explicit_euler": 0.0, "midpoint": 0.0, "heun": 0.0,
          "rk2": 0.0, "implicit_euler": math.inf, "baraff_witkin": math.inf}
CRITERION = Criterion(stress.PERIODS)


@pytest.fixture(scope="module")
def spring():
    return Spring()


def parse(*argv):
    parser = argparse.ArgumentParser()
    stress_cli.add_arguments(parser)
    return parser.parse_args(list(argv))


# 1. theory from the declared family / tableau ----------------------------------------------
@pytest.mark.parametrize("name, limit", THEORY.items())
def test_theory_from_family_and_tableau(name, limit):
    digits = 5e-6 if name == "dopri5" else 1e-12  # 0.99719 is quoted to 5 digits
    assert theory(get_integrator(name)) == pytest.approx(limit, abs=digits)


def test_finite_time_predictions_match_modified_energy_and_rk4_growth():
    """Symplectic Euler from rest peaks at E0 / (1 - y/2): the criterion lands at 2 - 2/F;
    RK4 past 2 sqrt 2 grows by |R(iy)|^2 ~ 1 + 5 (y - 2 sqrt 2) per step."""
    se, rk4 = get_integrator("symplectic_euler"), get_integrator("rk4")
    assert finite_time(se, 2.0, CRITERION)[0] == pytest.approx(2 - 2 / CRITERION.factor)
    y_ft, res = finite_time(rk4, theory(rk4), CRITERION)
    growth_steps = math.log(CRITERION.factor) / (5.03 * CRITERION.steps(2.83))
    assert res == pytest.approx(growth_steps, rel=0.02) and res < 1e-3


# 2. measured limits ------------------------------------------------------------------------
@pytest.mark.parametrize("name, periods, tol", [
    ("symplectic_euler", stress.PERIODS, 1e-5), ("velocity_verlet", stress.PERIODS, 1e-5),
    ("rk4", stress.PERIODS, 1e-5), ("dopri5", 200, 1e-4)])
def test_refsim_limit_matches_theory(spring, name, periods, tol):
    """Batched search on the in-house engine: on the criterion's own prediction to the
    bisection tolerance, and within the stated resolution of the asymptotic theory (1e-3
    for the first three at the default 1000 periods; dopri5's growth past 0.99719 is so slow
    that the criterion lands far above it, which `finite_time` predicts)."""
    crit, stepper = Criterion(periods), get_integrator(name)
    found = find_limit(get_engine("refsim"), name, spring, crit, tol)
    y_ft, res = finite_time(stepper, theory(stepper), crit)
    assert found.batched
    assert abs(found.limit - y_ft) <= 2 * tol * max(1.0, y_ft)
    assert stress.agrees(found.limit, theory(stepper), res, tol)
    if name != "dopri5":
        assert abs(found.limit - THEORY[name]) < 1e-3


def test_implicit_euler_limit_is_unbounded(spring):
    found = find_limit(get_engine("refsim"), "implicit_euler", spring, CRITERION, 1e-3)
    assert found.limit == math.inf and not found.batched and found.fallback
    assert "stable to 1000" in stress.limit_note(found, math.inf, 0.0)


def test_never_stable_methods_give_the_finite_time_value(spring):
    found = find_limit(get_engine("refsim"), "explicit_euler", spring, Criterion(100), 1e-3)
    y_ft, _ = finite_time(get_integrator("explicit_euler"), 0.0, Criterion(100))
    assert abs(found.limit - y_ft) <= 2e-3
    assert "unstable at every y" in stress.limit_note(found, 0.0, y_ft)


def test_batched_and_per_sim_agree(spring):
    """The vectorised run and one refsim Sim per y judge the same y the same way."""
    engine, crit = get_engine("refsim"), Criterion(200)
    ys = [1.99, 1.9997, 2.0005, 2.2]
    batched, _ = batch_evaluator(engine, "symplectic_euler", spring, crit)
    per_sim = sim_evaluator(engine, "symplectic_euler", spring, crit)
    for y in ys:  # one at a time: the batch presumes y below a stable y stable
        assert batched([y])[0] == per_sim([y])[0], y


def test_batch_stepper_offered_for_rk4_and_refused_for_implicit_euler(spring):
    engine = get_engine("refsim")
    sim = engine.build(spring.scene, 0.01, "rk4")
    stepper, why = batch_stepper(sim, spring)
    assert stepper is not None and why == ""
    sim = engine.build(spring.scene, 0.01, "implicit_euler")
    stepper, why = batch_stepper(sim, spring)
    assert stepper is None and "implicit_euler" in why


@pytest.mark.parametrize("engine, integrator", [("pymunk", "symplectic_euler_dk"),
                                                ("mujoco", "symplectic_euler")])
def test_external_engine_limit_is_the_criterions_value_near_two(spring, engine, integrator):
    pytest.importorskip(engine)
    crit = Criterion(300)
    found = find_limit(get_engine(engine), integrator, spring, crit, 1e-4)
    assert not found.batched
    assert abs(found.limit - (2 - 2 / crit.factor)) <= 2.5e-4
    assert stress.agrees(found.limit, 2.0, finite_time(get_integrator("symplectic_euler"), 2.0,
                                                      crit)[1], 1e-4)


# 3. stiffness sweep and taxonomy ------------------------------------------------------------
def _dt_at(y, k):
    """The step giving y = w dt on the stress probe (the stiff spring's default mass)."""
    from refsim.registry import get_case
    return y / (k / get_case("stiff_spring").params["mass"].default) ** 0.5


@pytest.mark.parametrize("k", [1e6, 1e8])
def test_explicit_euler_sweep_row_reports_growth(k):
    row = stress_sweep.sweep_point(get_engine("refsim"), "explicit_euler", k, _dt_at(1.0, k), 2.0)
    assert row["y"] >= 1 and row["failure"] in ("energy_growth", "nan_inf")


@pytest.mark.parametrize("k, y", [(1e6, 10.0), (1e7, 3.2)])
def test_implicit_euler_sweep_row_reports_artificial_damping(k, y):
    """Backward Euler keeps 1/(1 + y^2) of the energy per step: at y = 10 nothing is left."""
    row = stress_sweep.sweep_point(get_engine("refsim"), "implicit_euler", k, _dt_at(y, k), 2.0)
    assert row["y"] > 3 and row["failure"] == "artificial_damping"
    assert row["energy_ratio"] < 1e-6


def test_mujoco_discrete_damps_and_euler_reports_its_reset():
    pytest.importorskip("mujoco")
    engine = get_engine("mujoco")
    if "discrete" not in engine.integrators:
        pytest.skip("this MuJoCo adapter offers no discrete integrator")
    assert stress_sweep.sweep_point(engine, "discrete", 1e8, 1e-3, 2.0)["failure"] == \
        "artificial_damping"
    row = stress_sweep.sweep_point(engine, "symplectic_euler", 1e8, 1e-3, 2.0)
    assert row["failure"] == "silent_reset" and "energy >=" in row["detail"]


def test_classify_labels_each_failure_and_prefers_nan_reset_and_engine_failure():
    classify = stress_sweep.classify
    assert classify({}, 0.5)["failure"] == "none"
    assert classify({}, 1e-3)["failure"] == "artificial_damping"
    assert classify({"energy_growth": 4}, 2e4) == {
        "failure": "energy_growth", "at_step": 4, "energy_ratio": 2e4, "detail": ""}
    assert classify({"energy_growth": 4, "nan_inf": 9}, 2e4)["failure"] == "nan_inf"
    assert classify({"energy_growth": 4, "reset": 7}, 1.0)["failure"] == "silent_reset"
    bad = classify({"energy_growth": 3, "failure": 5}, 1.0, "mujoco reported mjWARN_BADQACC")
    assert bad["failure"] == "silent_reset" and bad["at_step"] == 5
    assert classify({"failure": 2}, 1.0, "Newton did not converge")["failure"] == \
        "engine_failure"


def test_sweep_runs_symplectic_euler_first_then_the_named_integrators_offered():
    assert stress_sweep.sweep_integrators(get_engine("refsim")) == [
        "symplectic_euler", "explicit_euler", "rk4", "implicit_euler"]
    assert stress_sweep.sweep_integrators(get_engine("refsim"), ["rk4", "discrete"]) == ["rk4"]


# 4. command: store, output, bad input -------------------------------------------------------
@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    """One quick stress run on refsim's symplectic and implicit Euler: (run dir, stdout)."""
    out_dir = tmp_path_factory.mktemp("stress")
    args = parse("--engine", "refsim", "--integrator", "symplectic_euler", "--integrator",
                 "implicit_euler", "--quick", "--out", str(out_dir))
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert stress_cli.main(args) == 0
    (run,) = out_dir.iterdir()
    return run, printed.getvalue()


def test_quick_run_writes_both_tables_and_manifest(quick_run):
    run, out = quick_run
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["status"] == "complete" and manifest["kind"] == "stress"
    assert manifest["command"].startswith("refsim stress --engine refsim")
    assert "git_commit" in manifest and set(manifest["engines"]) == {"refsim"}
    limits = (run / "stress_limits.csv").read_text().splitlines()
    sweep = (run / "stress_sweep.csv").read_text().splitlines()
    assert len(limits) == 3 and len(sweep) == 1 + 2 * len(stress_sweep.SWEEP_K)
    assert "energy is < 10000 E0" in out and "F = 10000 because" in out
    assert "artificial_damping:" in out and str(run) in out


def test_quick_run_is_an_ordinary_stored_run(quick_run):
    """results.csv: one row per limit (err_max = |measured - theory| in y, within the bound
    `agrees` uses) and per sweep run (status from the failure label), KEY unique, and a
    stored definition for every variant."""
    run, _ = quick_run
    table = load_results(run)
    assert len(table) == 2 + 2 * len(stress_sweep.SWEEP_K) and not table.duplicated(KEY).any()
    limits = table[table.variant == "stability_limit"].set_index("integrator")
    se, ie = limits.loc["symplectic_euler"], limits.loc["implicit_euler"]
    # same operations: limit_error's abs(measured - theory), theory 2.0
    assert se.err_max == abs(se.measured - 2.0) and se.err_max <= se.tolerance
    # the stored tolerance is where the printed verdict (stress.agrees) turns: just inside it
    # a measured limit agrees with the theory, just outside it does not
    assert se.tolerance > se.resolution
    for side, agreed in ((1 - 1e-9, True), (1 + 1e-9, False)):
        assert stress.agrees(2.0 + side * se.tolerance, 2.0, se.resolution,
                             stress.QUICK_TOL) is agreed
    assert ie.measured == math.inf and ie.err_max == 0.0 and ie.tolerance == 0.0
    assert limits.consistency.tolist() == ["consistent"] * 2 and set(limits.status) == {"ok"}
    assert limits.dt.isna().all()
    sweep = table[table.variant != "stability_limit"]
    assert ((sweep.status == "ok") == (sweep.failure == "none")).all()
    damped = sweep[sweep.failure == "artificial_damping"]
    assert len(damped) and set(damped.status) == {"diverged"}
    assert damped.reason.str.startswith("artificial_damping").all()
    # same operations: the store's abs(ratio - 1.0) on the same double (CSV repr is exact)
    assert np.array_equal(sweep.energy_drift, (sweep.energy_ratio - 1).abs(), equal_nan=True)
    definitions = {d["variant"]: d for d in load_definitions_list(run)}
    assert set(definitions) == set(table.variant)
    assert all(d["units"] == "y = omega dt" and d["order_meaningful"] is False
               for d in definitions.values())
    # the limits declare the measured-against-theory figure; the sweep rows none
    assert [f["kind"] for f in definitions["stability_limit"]["figures"]] == ["stability_limits"]
    assert all(d["figures"] == [] for v, d in definitions.items() if v != "stability_limit")


def test_report_and_compare_read_the_stress_run(quick_run, tmp_path):
    run, _ = quick_run
    md, _ = write_report(run, out=tmp_path)
    text = md.read_text()
    assert "## stiff_spring / stability_limit" in text and "| inf | inf |" in text
    figure = tmp_path / "plots" / "stiff_spring-stability_limit-fig0.png"
    assert figure.stat().st_size > 1000 and figure.name in text
    assert "artificial_damping" in text and "Recommendation" not in text
    a = open_run("RUN_A", run)
    result = compare_runs(a, a, judge_time=False)
    assert len(result.compared) == len(a.rows) and result.regressions.empty
    assert result.refused.empty


def test_stored_limit_of_a_failed_search_and_sweep_labels():
    opts = {"criterion": Criterion(100), "tol": 1e-3, "span": 0.5}
    failed = {"engine": "x", "integrator": "rk4", "measured": math.nan, "theory": 2.0,
              "finite_time": 2.0, "resolution": 1e-3, "agrees": False,
              "note": "error: RuntimeError: boom"}
    row = stress_store.stored_limit_row(failed, opts, "probe", "r", {})
    assert row["status"] == "failed" and row["reason"] == "RuntimeError: boom"
    assert math.isnan(row["err_max"]) and row["consistency"] == ""
    no_theory, why = stress_store.limit_tolerance(math.nan, math.nan, 1e-3)
    assert math.isnan(no_theory) and why.startswith("no tolerance")
    assert stress_store.limit_error(1.5, math.inf) == math.inf
    assert stress_store.sweep_status("none", "", None) == ("ok", "")
    assert stress_store.sweep_status("error", "ValueError: x", None) == (
        "failed", "ValueError: x")
    assert stress_store.sweep_status("nan_inf", "non-finite state", 7) == (
        "diverged", "nan_inf at step 7: non-finite state")
    assert [stress_store.sweep_variant(k) for k in (1e4, 2.5e3)] == ["k=1e4", "k=2500"]


@pytest.mark.parametrize("argv, name", [
    (("--periods", "0"), "--periods"), (("--periods", "x"), "--periods"),
    (("--dt", "-1"), "--dt"), (("--dt", "nan"), "--dt"),
    (("--engine", "nope"), "--engine"), (("--integrator", "nope"), "--integrator"),
    (("--integrator", "dopri5_adaptive"), "--integrator")])
def test_bad_input_names_the_parameter(tmp_path, argv, name):
    with pytest.raises(ValueError, match=f"^{name} "):
        stress_cli.main(parse(*argv, "--out", str(tmp_path)))
    assert not any(tmp_path.iterdir())


def test_no_engine_package_or_matplotlib_at_import():
    code = ("import sys, refsim.stress.limits; print(sorted(m for m in ('mujoco', 'pybullet', "
            "'pymunk', 'taichi', 'matplotlib') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"
