"""`refsim compare`: identical runs pass; worse errors, broken rows, lost tolerances and slower
steps are regressions (exit 1); changed cases are refused, never compared; bad input raises."""
import argparse
import json
import shutil

import numpy as np
import pytest

from refsim.cli import compare as compare_cli
from refsim.report import compare
from refsim.store.runs import open_run, parse_renames

from refsim.run import runner
from refsim.store.results import RunStore, environment, load_results

CASES = ["free_fall", "stiff_spring"]


@pytest.fixture(scope="module")
def baseline(tmp_path_factory):
    """A real stored run: free_fall and stiff_spring on refsim, two integrators (4 rows)."""
    from refsim.registry import get_case
    jobs = runner.expand(cases=CASES, engines=["refsim"],
                         integrators=["symplectic_euler", "velocity_verlet"], quick=True)
    hashes = {c: get_case(c).source_hash() for c in CASES}
    manifest = {"run_id": "base", **environment({"refsim": "0.1.0"}, hashes, 1)}
    store = RunStore.create(tmp_path_factory.mktemp("runs"), manifest)
    runner.run_matrix(jobs, store, repeats=1, budget_s=0.05)
    return store.dir


@pytest.fixture
def runs(baseline, tmp_path):
    """Copies A and B of the baseline run, and helpers to edit B."""
    a, b = tmp_path / "a", tmp_path / "b"
    shutil.copytree(baseline, a)
    shutil.copytree(baseline, b)
    return a, b


def edit_rows(run_dir, where, **changes):
    table = load_results(run_dir)
    mask = np.ones(len(table), bool)
    for col, value in where.items():
        mask &= table[col] == value
    assert mask.any()
    for col, change in changes.items():
        table.loc[mask, col] = change(table.loc[mask, col]) if callable(change) else change
    table.to_csv(run_dir / "results.csv", index=False, na_rep="nan")


def edit_manifest(run_dir, change):
    manifest = json.loads((run_dir / "manifest.json").read_text())
    change(manifest)
    (run_dir / "manifest.json").write_text(json.dumps(manifest))


def run_compare(a, b, *options):
    parser = argparse.ArgumentParser()
    compare_cli.add_arguments(parser)
    return compare_cli.main(parser.parse_args([str(a), str(b), *options]))


def verdicts(a, b, **kw):
    result = compare.compare_runs(open_run("RUN_A", a), open_run("RUN_B", b),
                                  **kw)
    return {(r.case, r.integrator): (r.verdict, r.reasons) for r in
            result.compared.itertuples()}, result


SE, VV = "symplectic_euler", "velocity_verlet"


def test_identical_runs_pass(runs, capsys):
    assert run_compare(*runs) == 0
    out = capsys.readouterr().out
    assert "compared 4, refused 0, only in A 0, only in B 0, regressions 0" in out
    for col in ("err_a", "err_b", "err_ratio", "us_a", "us_b", "time_ratio", "verdict"):
        assert col in out


def test_doubled_error_is_a_regression_above_round_off_only(runs, capsys):
    a, b = runs
    edit_rows(b, {"case": "free_fall"}, err_max=lambda e: 2 * e)
    got, _ = verdicts(a, b)
    assert got[("free_fall", SE)][0] == "regression" and "error x2" in got[("free_fall", SE)][1]
    # velocity Verlet is exact on free fall: its 1e-13 error is round-off, doubled or not
    assert got[("free_fall", VV)][0] == "ok"
    assert run_compare(a, b, "--no-time") == 1
    out = capsys.readouterr().out
    assert "regressions 1" in out
    assert "REGRESSION free_fall/default refsim symplectic_euler dt=0.001: error x2" in out


def test_error_within_threshold_is_ok_and_halved_error_is_improved(runs):
    a, b = runs
    edit_rows(b, {"case": "stiff_spring", "integrator": SE}, err_max=lambda e: 1.05 * e)
    edit_rows(b, {"case": "stiff_spring", "integrator": VV}, err_max=lambda e: 0.5 * e)
    got, _ = verdicts(a, b, judge_time=False)
    assert got[("stiff_spring", SE)][0] == "ok"
    assert got[("stiff_spring", VV)][0] == "improved"
    assert run_compare(a, b, "--no-time") == 0
    assert run_compare(a, b, "--no-time", "--error-threshold", "1.01") == 1


def test_diverged_row_is_a_regression_and_fixed_row_is_not(runs):
    a, b = runs
    edit_rows(b, {"case": "stiff_spring", "integrator": SE}, status="diverged",
              reason="non-finite state at t=0.1 s", err_max=np.nan, consistency="")
    got, _ = verdicts(a, b)
    verdict, why = got[("stiff_spring", SE)]
    assert verdict == "regression" and "status ok -> diverged (non-finite state" in why
    assert run_compare(a, b) == 1
    # the other way round: diverged in A, ok in B is a fix
    back, _ = verdicts(b, a)
    assert back[("stiff_spring", SE)][0] == "improved"


def test_nan_error_in_an_ok_row_is_a_regression(runs):
    a, b = runs
    edit_rows(b, {"case": "free_fall", "integrator": VV}, err_max=np.nan)
    got, _ = verdicts(a, b)
    verdict, why = got[("free_fall", VV)]
    assert verdict == "regression" and "-> nan" in why


def test_becoming_inconsistent_or_missing_the_target_is_a_regression(runs):
    a, b = runs
    edit_rows(b, {"case": "stiff_spring", "integrator": VV}, consistency="inconsistent")
    got, _ = verdicts(a, b, judge_time=False)
    assert got[("stiff_spring", VV)][0] == "regression"
    assert "now inconsistent with its method" in got[("stiff_spring", VV)][1]
    edit_rows(b, {"case": "stiff_spring", "integrator": VV}, consistency="consistent")
    table = load_results(a)
    first = table[table["reaches_target"].astype(str) == "True"].iloc[0]
    reached = (first["case"], first["integrator"])
    edit_rows(b, {"case": reached[0], "integrator": reached[1]}, reaches_target=False)
    got, _ = verdicts(a, b, judge_time=False)
    assert "no longer reaches the target" in got[reached][1]


def test_slower_steps_are_a_regression_unless_time_is_ignored(runs):
    a, b = runs
    edit_rows(b, {"case": "free_fall", "integrator": SE}, us_per_step=lambda u: 3 * u)
    edit_rows(b, {"case": "free_fall", "integrator": VV}, us_per_step=lambda u: 1.3 * u)
    got, _ = verdicts(a, b)
    assert got[("free_fall", SE)][0] == "regression" and "time x3" in got[("free_fall", SE)][1]
    assert got[("free_fall", VV)][0] == "ok"  # 1.3 is within the default 1.5
    assert run_compare(a, b) == 1
    assert run_compare(a, b, "--no-time") == 0
    assert run_compare(a, b, "--time-threshold", "4") == 0


def test_changed_case_source_is_refused_not_compared(runs, capsys):
    a, b = runs
    edit_manifest(b, lambda m: m["case_hashes"].update(free_fall="0123456789abcdef"))
    edit_rows(b, {"case": "free_fall"}, err_max=lambda e: 100 * e)  # would be a regression
    got, result = verdicts(a, b)
    assert set(result.refused["case"]) == {"free_fall"} and len(result.refused) == 2
    assert all("case source changed" in r for r in result.refused["reason"])
    assert {case for case, _ in got} == {"stiff_spring"}
    assert run_compare(a, b) == 0
    out = capsys.readouterr().out
    assert "refused 2" in out and "refused    free_fall/default refsim symplectic_euler" in out


def test_missing_hash_and_different_parameters_are_refused(runs):
    a, b = runs
    edit_manifest(a, lambda m: m["case_hashes"].pop("free_fall"))
    edit_rows(b, {"case": "stiff_spring"}, params=json.dumps({"zeta": 0.5}))
    _, result = verdicts(a, b)
    reasons = dict(zip(zip(result.refused["case"], result.refused["integrator"]),
                       result.refused["reason"]))
    assert "missing from run A's manifest" in reasons[("free_fall", SE)]
    assert "case parameters differ" in reasons[("stiff_spring", VV)]
    with pytest.raises(ValueError, match="RUN_B must share at least one comparable row"):
        run_compare(a, b)


def test_rows_in_one_run_only_are_counted(runs, capsys):
    a, b = runs
    table = load_results(b)
    table[table["case"] == "free_fall"].to_csv(b / "results.csv", index=False, na_rep="nan")
    assert run_compare(a, b) == 0
    assert "compared 2, refused 0, only in A 2, only in B 0" in capsys.readouterr().out


def test_out_writes_the_compared_rows(runs, tmp_path):
    a, b = runs
    edit_rows(b, {"case": "free_fall", "integrator": SE}, err_max=lambda e: 2 * e)
    assert run_compare(a, b, "--no-time", "--out", str(tmp_path / "cmp.csv")) == 1
    import pandas as pd
    written = pd.read_csv(tmp_path / "cmp.csv")
    assert len(written) == 4 and list(written["verdict"]).count("regression") == 1
    assert {"err_ratio", "time_ratio", "reasons", "norm"} <= set(written.columns)


@pytest.mark.parametrize("options,names", [
    (["--error-threshold", "1"], "--error-threshold must be a finite number > 1"),
    (["--error-threshold", "0.5"], "--error-threshold must be a finite number > 1"),
    (["--error-threshold", "nan"], "--error-threshold must be a finite number > 1"),
    (["--time-threshold", "abc"], "--time-threshold must be a finite number > 1"),
    (["--time-threshold", "inf"], "--time-threshold must be a finite number > 1"),
    (["--out", "."], "--out must be a FILE.csv path"),
])
def test_bad_options_raise_naming_the_parameter(runs, options, names):
    with pytest.raises(ValueError, match=names):
        run_compare(*runs, *options)


def test_a_path_that_is_not_a_stored_run_raises(runs, tmp_path):
    a, b = runs
    with pytest.raises(ValueError, match="RUN_A must be a stored run directory"):
        run_compare(tmp_path / "nope", b)
    (b / "manifest.json").unlink()
    with pytest.raises(ValueError, match="RUN_B must be a stored run directory"):
        run_compare(a, b)


def test_rename_maps_a_reorganised_case_row_for_row(runs, capsys):
    a, b = runs
    edit_rows(a, {"case": "free_fall"}, case="old_fall")
    edit_manifest(a, lambda m: m["case_hashes"].update(old_fall=m["case_hashes"]["free_fall"]))
    assert run_compare(a, b) == 0  # nothing of old_fall matches: stiff_spring alone
    assert "compared 2," in capsys.readouterr().out
    assert run_compare(a, b, "--rename", "old_fall=free_fall") == 0
    assert "compared 4, refused 0, only in A 0, only in B 0" in capsys.readouterr().out
    assert run_compare(a, b, "--rename", "old_fall/default=free_fall/default") == 0
    assert "compared 4," in capsys.readouterr().out


@pytest.mark.parametrize("spec", ["old_fall", "=free_fall", "a/v=b", "a=b/v"])
def test_rename_must_name_both_sides_alike(spec):
    with pytest.raises(ValueError, match="--rename must be OLD=NEW"):
        parse_renames([spec])


def test_changed_source_is_refused_unless_allowed_and_then_said(runs):
    a, b = runs
    edit_manifest(b, lambda m: m["case_hashes"].update(free_fall="0" * 16))
    got, result = verdicts(a, b)
    assert len(result.refused) == 2 and all("case source changed" in r
                                            for r in result.refused["reason"])
    got, result = verdicts(a, b, allow_source_change=True)
    assert result.refused.empty
    assert all("--allow-source-change" in got[("free_fall", i)][1] for i in (SE, VV))
    assert got[("stiff_spring", SE)][1] == ""
