"""Where jobs run (refsim.run.executors): a job whose engine aborts, segfaults or hangs is one row
(`failed` naming the signal, `timeout`) and every other row is there, on the local executor and
on a Dask cluster; both give the rows of the in-process run; a run killed with SIGKILL loses
no finished row and redoes none on --resume."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from example_engine import PointMassEngine, PointMassSim

from refsim import registry

from refsim.run import executors
from refsim.run.runner import expand, run_matrix
from refsim.run.sandbox import death_reason
from refsim.store.results import RunStore, read_journal, row_key

HANG_S = 600.0
# long enough for a fresh sandbox child to start and import refsim on a loaded 2-core
# machine (4 s timed a SIGSEGV job out while 8 processes shared the cores)
TIMEOUT_S = 8.0


class AbortSim(PointMassSim):
    def step(self, n):
        os.abort()


class SegvSim(PointMassSim):
    def step(self, n):
        os.kill(os.getpid(), signal.SIGSEGV)


class HangSim(PointMassSim):
    def step(self, n):
        time.sleep(HANG_S)


class AbortEngine(PointMassEngine):
    name, sim_class = "abort_engine", AbortSim


class SegvEngine(PointMassEngine):
    name, sim_class = "segv_engine", SegvSim


class HangEngine(PointMassEngine):
    name, sim_class = "hang_engine", HangSim


CRASHING = {"abort_engine": "AbortEngine", "segv_engine": "SegvEngine",
            "hang_engine": "HangEngine"}
EXPECTED = {"abort_engine": ("failed", "worker died: SIGABRT"),
            "segv_engine": ("failed", "worker died: SIGSEGV"),
            "hang_engine": ("timeout", f"no result within --timeout {TIMEOUT_S:g} s "
                                       "(worker killed and replaced)")}


@pytest.fixture
def crashing_engines():
    # registered in this process; the executors send run-time registrations to their workers
    for name, cls in CRASHING.items():
        registry.register("engine", name, f"{__name__}:{cls}")
    yield
    for name in CRASHING:
        registry.unregister("engine", name)


def _crash_jobs():
    # two sound jobs after the crashing ones: each worker must be replaced to run them
    return expand(["free_fall"], [*CRASHING, "refsim"], ["symplectic_euler"],
                  [0.01, 0.005], variants=["default"])


def _run(tmp_path, name, jobs, executor):
    store = RunStore.create(tmp_path, {"run_id": name})
    return run_matrix(jobs, store, repeats=1, budget_s=0.05, executor=executor)


def _outcomes(table):
    return {(r.engine, r.dt): (r.status, r.reason) for r in table.itertuples()}


def _check_crash_rows(table, jobs):
    assert len(table) == len(jobs) == 8
    for (engine, dt), outcome in _outcomes(table).items():
        assert outcome == (EXPECTED[engine] if engine in EXPECTED else ("ok", "")), engine
    assert (table["host"].astype(str).str.len() > 0).all()


def test_death_reason_names_the_signal_or_the_exit_code():
    assert death_reason(-signal.SIGABRT) == "worker died: SIGABRT"
    assert death_reason(-signal.SIGKILL) == "worker died: SIGKILL"
    assert death_reason(3) == "worker died: exit code 3"


def test_local_executor_turns_abort_segfault_and_hang_into_rows(crashing_engines, tmp_path):
    jobs = _crash_jobs()
    start = time.perf_counter()
    table = _run(tmp_path, "local", jobs, executors.Local(2, timeout=TIMEOUT_S))
    _check_crash_rows(table, jobs)
    hung = table[table["engine"] == "hang_engine"]
    assert (hung["wall_s"] >= TIMEOUT_S).all() and (hung["wall_s"] < TIMEOUT_S + 3).all()
    assert time.perf_counter() - start < HANG_S / 4  # the hung workers were killed


# what the in-process and the executors' rows are compared on: an explicit, a fourth-order, an
# implicit (Newton's linear solves, where BLAS threads could change the rounding: the worker
# processes run on one) and an adaptive stepper (its controller's state) on two cases; the
# quick matrix's other ten integrators of these cases run the same code (8 jobs, not 28)
SAME_ROWS_INTEGRATORS = ["symplectic_euler", "rk4", "baraff_witkin", "dopri5_adaptive"]


def _one_per_engine(jobs):
    """The first job of each case x engine x formulation: every engine's adapter in a worker,
    one job each (the rest of the quick matrix runs the same adapter)."""
    first = {}
    for job in jobs:
        first.setdefault((job.case, job.engine, job.engine_variant), job)
    return list(first.values())


def test_local_executor_rows_equal_the_in_process_rows(tmp_path):
    jobs = expand(["stiff_spring", "pendulum"], ["refsim"], SAME_ROWS_INTEGRATORS, quick=True)
    assert len(jobs) == 8
    here = _run(tmp_path, "here", jobs, executors.InProcess())
    there = _run(tmp_path, "there", jobs, executors.Local(2))
    _assert_same_results(here, there)


def _assert_same_results(a, b):
    key = ["case", "variant", "engine", "engine_variant", "integrator", "dt"]
    a, b = a.sort_values(key).reset_index(drop=True), b.sort_values(key).reset_index(drop=True)
    assert a[key].equals(b[key])
    for col in ("status", "reason", "err_max", "err_final", "energy_drift", "consistency",
                "reaches_target"):
        assert a[col].equals(b[col]), col


@pytest.mark.slow
def test_dask_local_cluster_isolates_crashes_and_hangs(crashing_engines, tmp_path):
    pytest.importorskip("distributed")
    jobs = _crash_jobs()
    table = _run(tmp_path, "dask", jobs, executors.Dask(workers=2, timeout=TIMEOUT_S))
    _check_crash_rows(table, jobs)


@pytest.mark.slow
def test_dask_scheduler_runs_the_rows_of_the_local_run(tmp_path):
    LocalCluster = pytest.importorskip("distributed").LocalCluster
    # the installed engines only: a class registered at run time by another test in this
    # process (refsim.testing's factories) exists in no other process
    from refsim.registry import entries, get_engine
    installed = [n for n, e in entries("engine").items() if e.origin != "registered at run time"
                 and not get_engine(n).peer]  # a peer runs only where named
    jobs = _one_per_engine(expand(["stiff_spring", "pendulum"], installed, quick=True))
    assert {j.engine for j in jobs} == set(installed)
    local = _run(tmp_path, "local", jobs, executors.Local(2))
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        remote = _run(tmp_path, "remote", jobs, executors.Dask(cluster.scheduler_address))
    bad = remote[remote["status"] != "ok"]
    assert bad.empty, bad[["engine", "integrator", "status", "reason"]].to_string()
    _assert_same_results(local, remote)
    assert len(remote) == len(jobs)


def _refsim(*args, **kw):
    return subprocess.Popen([sys.executable, "-m", "refsim", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kw)


@pytest.mark.slow
def test_sigkill_mid_run_then_resume_loses_and_redoes_no_row(tmp_path):
    # 14 jobs of 0.05-0.2 s (two engines, two cases): the kill lands after the fourth row with
    # about a second of jobs left (the quick matrix's other 16 refsim integrators added 4 s)
    integrators = [a for name in ("symplectic_euler", "symplectic_euler_dk", "explicit_euler",
                                  "midpoint", "heun", "rk4") for a in ("--integrator", name)]
    args = ["--quick", "--case", "stiff_spring", "--case", "pendulum", "--engine", "refsim",
            "--engine", "pymunk", *integrators, "--out", str(tmp_path), "--no-report",
            "--jobs", "1", "--repeats", "1"]
    proc = _refsim("run", *args)
    journal = _wait_for_rows(tmp_path, proc, at_least=4)
    proc.kill()  # SIGKILL: nothing of refsim runs after it
    proc.wait()
    before = read_journal(journal)
    run_dir = journal.parent
    total = json.loads((run_dir / "manifest.json").read_text())["jobs"]
    assert 4 <= len(before) < total, "the kill must land mid-run"
    resumed = _refsim("run", "--resume", run_dir.name, "--out", str(tmp_path), "--no-report")
    out, err = resumed.communicate(timeout=600)
    assert resumed.returncode == 0, err[-2000:]
    after = read_journal(journal)
    assert after[:len(before)] == before  # no finished row lost or rewritten
    keys = [row_key(r) for r in after]
    assert len(keys) == len(set(keys)) == total  # none redone, none missing


def _wait_for_rows(root, proc, at_least):
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and proc.poll() is None:
        for journal in Path(root).glob("*/rows.jsonl"):
            if len(journal.read_text().splitlines()) >= at_least:
                return journal
        time.sleep(0.02)
    raise AssertionError(f"no {at_least} rows before the run ended: {proc.poll()}")


@pytest.mark.parametrize("flags, message", [
    (["--timeout", "0"], "--timeout must be a finite number > 0 s"),
    (["--timeout", "abc"], "--timeout must be a finite number > 0 s"),
    (["--dask-workers", "0"], "--dask-workers must be an integer >= 1"),
    (["--scheduler", "tcp://127.0.0.1:1", "--dask-workers", "2"], "must not be given together"),
])
def test_bad_executor_flags_exit_2_with_one_line(flags, message, tmp_path, capsys):
    from refsim.cli import main
    with pytest.raises(SystemExit) as exit_info:
        main(["run", "--case", "free_fall", "--out", str(tmp_path), *flags])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1
    assert not list(tmp_path.iterdir())  # nothing stored
