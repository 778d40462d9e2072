"""The work of a run: summed per group, measured from a stored run, predicted for a matrix
(refsim.run.budget), and the default matrix's prediction against the default run's budget."""
from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest

from refsim.run.budget import measure, predict, work_by
from refsim.run.job import Job
from refsim.run.runner import expand

MEASURED = json.loads(Path(__file__).with_name("default_run_work.json").read_text())
# The README's promise: install + `refsim run` (run and report) within 5 minutes on 2 cores;
# install measured at 60-85 s from a fresh clone, so the run and its report get 215 s.
DEFAULT_RUN_BUDGET_S = 215.0
WORKERS = 2


def _default_matrix():
    """The default run's jobs on the installed engines and cases (not those another test
    registered at run time in this process: `refsim run` never sees them)."""
    from refsim.registry import entries, get_engine
    installed = [n for n, e in entries("engine").items() if e.origin != "registered at run time"
                 and not get_engine(n).peer]  # a peer runs only where named
    cases = [n for n, e in entries("case").items() if e.origin != "registered at run time"]
    return expand(cases=cases, engines=installed)


def _table():
    return pd.DataFrame({"case": ["a", "a", "b", "b", "b"], "variant": ["v"] * 5,
                         "engine": ["x", "y", "x", "x", "x"],
                         "wall_s": [1.0, 3.0, 2.0, 2.0, "nan"]})


def test_work_is_summed_per_group_largest_first_with_its_share():
    out = work_by(_table(), ["case", "engine"])
    assert out[["case", "engine"]].values.tolist() == [["b", "x"], ["a", "y"], ["a", "x"]]
    assert out["work_s"].tolist() == [4.0, 3.0, 1.0]  # a row without a wall time counts 0
    assert out["jobs"].tolist() == [3, 1, 1]
    assert out["share"].sum() == pytest.approx(1.0)


def test_prediction_sums_each_jobs_measured_mean_and_lists_the_unmeasured(tmp_path):
    _table().to_csv(tmp_path / "results.csv", index=False)
    (tmp_path / "manifest.json").write_text(json.dumps({"run_id": "r", "cpu": "c",
                                                        "workers": 2, "wall_s": 5.0}))
    measured = measure(tmp_path)
    assert measured["job_s"] == {"b/v/x": 4.0 / 3, "a/v/y": 3.0, "a/v/x": 1.0}
    jobs = [Job("b", "v", "x", "", "rk4", dt) for dt in (0.1, 0.2)] + [
        Job("a", "v", "y", "", "rk4", 0.1), Job("c", "v", "x", "", "rk4", 0.1)]
    p = predict(jobs, measured)
    assert p.work_s == pytest.approx(2 * 4.0 / 3 + 3.0) and p.jobs == 3
    assert p.unmeasured == ["c/v/x"]
    assert p.wall_s(2, report_s=10.0) == pytest.approx(p.work_s / 2 + 10.0)


def test_every_job_of_the_default_matrix_was_measured():
    """A case, variant or engine added to the default run since the measurement has no
    prediction: measure it again (tests/harness/default_run_work.json, written by
    `python -m refsim.run.budget RUN_DIR tests/harness/default_run_work.json` from a
    default run)."""
    assert predict(_default_matrix(), MEASURED).unmeasured == []


def test_the_default_matrix_has_not_grown_since_its_measurement():
    """Each measured job at its group's mean sums to the measured work when the matrix is the
    one measured; a job added to the default run (another dt, variant, formulation) makes the
    prediction exceed it: measure again and hold it against the budget below."""
    p = predict(_default_matrix(), MEASURED)
    assert p.jobs <= MEASURED["jobs"]
    # the sum of per-group means times their counts: the measured total up to round-off
    assert p.work_s <= MEASURED["work_s"] * (1 + 1e-9)


@pytest.mark.xfail(strict=True, reason=(
    "issue 25 is open: the default run measured 371 s (704 s of row work on 2 workers, 2728 "
    "jobs with the FEM and grid-fluid groups) + 23 s of report from a fresh clone on a quiet "
    "Intel Xeon on 2026-11-27 08:40, against 215 s; strict: it fails once it fits, and this "
    "mark goes"))
def test_the_default_matrix_fits_the_default_run_budget():
    """The default matrix's predicted run and report (each job at its measured mean, the work
    spread over two workers) within DEFAULT_RUN_BUDGET_S: a test that fails when the default
    run grows past the README's five minutes. The measurement's machine is in the file."""
    p = predict(_default_matrix(), MEASURED)
    wall = p.wall_s(WORKERS, MEASURED["report_s"])
    assert wall <= DEFAULT_RUN_BUDGET_S, (
        f"the default run predicts {wall:.0f} s ({p.work_s:.0f} s of work over {WORKERS} "
        f"workers + {MEASURED['report_s']:.0f} s of report, measured on {MEASURED['cpu']}) "
        f"against {DEFAULT_RUN_BUDGET_S:.0f} s")
