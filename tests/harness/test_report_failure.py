"""A report that fails to render is not bad input: `refsim run` keeps every stored row, says
where they are and how to render them again, and exits 1 (exit 2 is for bad input only)."""
from __future__ import annotations

import pandas as pd

from refsim import cli


def _boom(run_dir):
    raise ValueError("bottom cannot be >= top")  # what matplotlib raised once in a heatmap


def test_a_failing_report_keeps_the_run_and_exits_1(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr("refsim.report.build.write_report", _boom)
    status = cli.main(["run", "--case", "free_fall", "--variant", "default", "--engine",
                       "refsim", "--integrator", "rk4", "--dt", "0.01", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert status == 1
    assert "the report failed (ValueError: bottom cannot be >= top)" in err
    assert "refsim: error" not in err
    run_dir = next(tmp_path.iterdir())
    assert f"refsim report {run_dir}" in err
    table = pd.read_csv(run_dir / "results.csv")
    assert list(table["status"]) == ["ok"]
