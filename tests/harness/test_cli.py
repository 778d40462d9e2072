"""The command line: listing, a small run end to end, resume, and bad input."""
import json
import subprocess
import sys
import warnings
from pathlib import Path

import pandas as pd
import pytest

from refsim.store.results import DEFAULT_ROOT, KEY, load_results, row_key


def refsim(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "refsim", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=300)


BAD_INPUT = [
    (["run", "--case", "nope"], "case must be one of"),
    (["run", "--dt", "-1"], "--dt must be a finite number > 0"),
    (["run", "--dt=-1"], "--dt must be a finite number > 0"),
    (["run", "--dt", "nan"], "--dt must be a finite number > 0"),
    (["run", "--dt", "abc"], "--dt must be a finite number > 0"),
    (["run", "--engine", "nope"], "engine must be one of"),
    (["run", "--integrator", "nope"], "integrator must be one of"),
    (["run", "--integrator", "rk2:1.5"], "rk2 alpha must be in (0, 1]"),
    (["run", "--case", "free_fall", "--param", "mass=-1"], "free_fall.mass must be in (0, "),
    (["run", "--case", "pendulum", "--param", "theta0=inf"], "pendulum.theta0 must be in"),
    (["run", "--param", "nosuch=1"], "--param 'nosuch' must be a parameter of"),
    (["run", "--case", "pendulum", "--variant", "nope"], "variant must be one of"),
    (["run", "--repeats", "0"], "--repeats must be an integer >= 1"),
    (["run", "--bogus"], "unrecognized arguments"),
    (["run", "--case", "free_fall", "--dt", "10"],
     "dt = 10 s is longer than the run of free_fall/default (t_end = 2 s): dt must be in (0, 2]"),
    (["run", "--case", "free_fall", "--dt", "1e-300"],
     "dt must be in [2e-08, 2] s, at most --max-steps 1e+08 steps"),
    (["run", "--case", "free_fall", "--dt", "1e-4", "--max-steps", "1000"],
     "dt = 0.0001 s gives 2e+04 steps for free_fall/default: dt must be in [0.002, 2] s"),
    (["run", "--max-steps", "0"], "--max-steps must be an integer >= 1"),
    (["run", "--max-steps", "1.5"], "--max-steps must be an integer >= 1"),
    (["run", "--threads", "abc"], "--threads must be an integer >= 1, got 'abc'"),
    (["run", "--threads", "0"], "--threads must be an integer >= 1, got '0'"),
    (["run", "--jobs", "0"], "--jobs must be an integer >= 1, got '0'"),
    (["run", "--integrator", "rk2:"], "integrator 'rk2:': a parameter must follow ':' (alpha "
                                      "in (0, 1]"),
]


@pytest.mark.parametrize("args,names", BAD_INPUT)
def test_bad_input_is_one_line_and_exit_2(args, names, tmp_path, capsys):
    """In this process: `python -m refsim` exits with main()'s SystemExit code and stderr
    (refsim/__main__.py); a real process's exit status and stderr for both ways bad input
    leaves (the parser's error, a ValueError of the command):
    test_bad_input_in_a_real_process. A warning is an error here (it would be a second
    line on a real stderr)."""
    from refsim.cli import main
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(SystemExit) as exit_info:
            main([*args, "--out", str(tmp_path)])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert names in lines[0]
    assert not any(tmp_path.iterdir()), "nothing may be written for bad input"


@pytest.mark.parametrize("args,names", [BAD_INPUT[13], BAD_INPUT[1], BAD_INPUT[16]],
                         ids=["parser", "option", "matrix"])
def test_bad_input_in_a_real_process(args, names, tmp_path):
    out = refsim(*args, "--out", str(tmp_path))
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in out.stderr, out.stderr
    assert names in lines[0]
    assert not any(tmp_path.iterdir()), "nothing may be written for bad input"


def test_list_shows_cases_engines_integrators():
    out = refsim("list")
    assert out.returncode == 0
    for word in ("free_fall", "stiff_spring", "pendulum", "refsim", "pybullet", "mujoco",
                 "pymunk", "taichi", "dopri5_adaptive", "baraff_witkin", "order 4"):
        assert word in out.stdout


def _small_run(tmp_path, *extra, dts=("0.01", "0.005")):
    dt_args = [a for dt in dts for a in ("--dt", dt)]
    out = refsim("run", "--case", "free_fall", "--engine", "refsim", "--integrator",
                 "symplectic_euler", "--integrator", "rk4", *dt_args,
                 "--variant", "default", "--repeats", "1", "--out", str(tmp_path), *extra)
    assert out.returncode == 0, out.stderr
    return out, Path(out.stdout.strip().splitlines()[-1])


def test_run_writes_table_and_manifest(tmp_path):
    # a decade of dt: the least a measured order is fitted over (refsim.run.metrics.fit_order)
    out, run_dir = _small_run(tmp_path, dts=("0.02", "0.01", "0.004", "0.002"))
    assert run_dir.parent == tmp_path and run_dir.is_dir()
    table = load_results(run_dir)
    assert len(table) == 8 and set(table["status"]) == {"ok"}
    for col in ("run_id", "case", "engine", "engine_version", "integrator", "dt", "steps",
                "t_end", "status", "reason", "err_max", "err_final", "err_rms", "energy_drift",
                "setup_s", "compile_s", "step_s", "us_per_step", "repeats", "settings",
                "order", "tolerance", "consistency", "consistency_reason", "reaches_target",
                "target_error", "declared_order", "err_initial", "timed_steps"):
        assert col in table.columns, col
    manifest = json.loads((run_dir / "manifest.json").read_text())
    assert manifest["status"] == "complete" and manifest["engines"]["refsim"]
    assert set(manifest["case_hashes"]) == {"free_fall"} and manifest["git_commit"]
    # measured order: semi-implicit Euler's free-fall error g t dt / 2 is exactly first order
    se = table[table["integrator"] == "symplectic_euler"]
    assert se["order"].iloc[0] == pytest.approx(1.0, abs=1e-6)
    assert "free_fall" in out.stdout and "symplectic_euler" in out.stdout


@pytest.mark.slow
def test_resume_finishes_without_redoing_rows(tmp_path):
    # no report of the first run (test_run_writes_table_and_manifest's writes one); the resumed
    # run writes its own
    _, run_dir = _small_run(tmp_path, "--no-report")
    table = load_results(run_dir)
    kept = table.iloc[:2]
    kept.to_csv(run_dir / "results.csv", index=False, na_rep="nan")  # as if interrupted
    journal = (run_dir / "rows.jsonl").read_text().splitlines()
    keys = {row_key(r) for r in kept.to_dict("records")}
    finished = [line for line in journal if row_key(json.loads(line)) in keys]
    cut = next(line for line in journal if row_key(json.loads(line)) not in keys)
    # the two finished rows, and a third cut off mid-write
    (run_dir / "rows.jsonl").write_text("\n".join(finished) + "\n" + cut[:40])
    manifest = json.loads((run_dir / "manifest.json").read_text())
    (run_dir / "manifest.json").write_text(json.dumps({**manifest, "status": "running"}))
    out = refsim("run", "--resume", run_dir.name, "--out", str(tmp_path))
    assert out.returncode == 0, out.stderr
    resumed = load_results(run_dir)
    assert len(resumed) == 4
    again = resumed.set_index(KEY).loc[kept.set_index(KEY).index]
    # finished rows are carried over as they were, not run again
    assert list(again["step_s"]) == list(kept["step_s"])


def test_resume_unknown_run_is_bad_input(tmp_path, capsys):
    from refsim.cli import main
    with pytest.raises(SystemExit) as exit_info:  # the exit status of `python -m refsim`
        main(["run", "--resume", "nope", "--out", str(tmp_path)])
    assert exit_info.value.code == 2
    assert "run must be a stored run directory" in capsys.readouterr().err


def test_max_steps_reads_digits_and_powers_of_ten():
    from refsim.options import integer
    assert integer("--max-steps", "1000") == 1000 and integer("--max-steps", "1e9") == 10 ** 9
