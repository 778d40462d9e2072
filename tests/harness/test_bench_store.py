"""`refsim bench NAME` writes an ordinary stored run: one row per figure, no tolerance, read by
`report` and judged by `compare` on time (and status) only."""
import json
import math

import pandas as pd
import pytest

from refsim import cli, registry
from refsim.report.compare import compare_runs
from refsim.cli.bench import run_bench
from refsim.store.figures import NO_TOLERANCE, check_figures, figure_rows
from refsim.report.build import write_report
from refsim.store.results import KEY, load_definitions_list, load_results, row_key
from ulp import assert_ulp
from refsim.store.runs import open_run

SPEED = {"us": 10.0, "ms": 4.0}  # what the tiny bench measures; a test slows it down


def tiny_figures() -> list[dict]:
    return [
        {"figure": "one_step", "value": SPEED["us"], "units": "us/step",
         "description": "a per-step figure", "engine": "refsim", "integrator": "rk4",
         "dt": 1e-3, "steps": 100, "us_per_step": SPEED["us"],
         "step_s": SPEED["us"] * 100e-6, "repeats": 3},
        {"figure": "to_target", "value": SPEED["ms"], "units": "ms",
         "description": "a whole computation", "engine": "scipy", "integrator": "DOP853",
         "time_us": SPEED["ms"] * 1e3, "time_column": "time_us", "err_reached": 5e-9,
         "show": ["err_reached"]},
    ]


def tiny_bench(quick=False):
    print("tiny bench: 2 figures")
    return tiny_figures()


def exit_code_bench(quick=False):
    return 3


@pytest.fixture
def benches():
    registry.register("bench", "tiny", f"{__name__}:tiny_bench")
    registry.register("bench", "exit_code", f"{__name__}:exit_code_bench")
    SPEED.update(us=10.0, ms=4.0)
    yield
    registry.unregister("bench", "tiny")
    registry.unregister("bench", "exit_code")


def _run(tmp_path, capsys):
    assert cli.main(["bench", "tiny", "--quick", "--out", str(tmp_path)]) == 0
    run_dir = capsys.readouterr().out.strip().splitlines()[-1]
    return open_run("RUN", run_dir)


# -- the figures as rows -----------------------------------------------------------------------
def test_rows_carry_the_figure_and_no_tolerance():
    rows = figure_rows(tiny_figures(), "bench:tiny", "r1", {"refsim": "0.1"})
    assert [(r["case"], r["variant"], r["engine"]) for r in rows] == [
        ("bench:tiny", "one_step", "refsim"), ("bench:tiny", "to_target", "scipy")]
    assert all(r["status"] == "ok" and r["consistency"] == "" and math.isnan(r["tolerance"])
               and r["tol_reason"] == NO_TOLERANCE and math.isnan(r["err_max"]) for r in rows)
    assert rows[0]["us_per_step"] == 10.0 and rows[0]["engine_version"] == "0.1"
    assert math.isnan(rows[1]["dt"]) and rows[1]["time_us"] == 4000.0  # 4.0 * 1e3: exact
    assert "time_column" not in rows[1] and "show" not in rows[1]


def test_figures_need_the_required_keys_and_distinct_keys():
    with pytest.raises(ValueError, match="without \\['units'\\]"):
        check_figures([{"figure": "a", "value": 1.0, "description": "d"}], "tiny")
    twice = [tiny_figures()[0], tiny_figures()[0]]
    with pytest.raises(ValueError, match="twice"):
        check_figures(twice, "tiny")


# -- the command: store, report, compare --------------------------------------------------------
def test_bench_command_stores_a_run_report_reads(benches, tmp_path, capsys):
    run = _run(tmp_path, capsys)
    assert run.manifest["kind"] == "bench" and run.manifest["status"] == "complete"
    assert set(run.manifest["case_hashes"]) == {"bench:tiny"}
    table = load_results(run.dir)
    assert len(table) == 2 and not table.duplicated(KEY).any()
    definitions = {d["variant"]: d for d in load_definitions_list(run.dir)}
    assert definitions["to_target"]["time_column"] == "time_us"
    assert definitions["one_step"]["time_column"] == "us_per_step"
    assert all(not d["order_meaningful"] and d["figures"] == [] for d in definitions.values())
    md, _ = write_report(run.dir)
    text = md.read_text()
    assert "ok (no tolerance)" in text and "above tolerance" not in text
    assert "| 4 | ms | 5e-09 |" in text  # value, units and the shown column


def test_compare_judges_time_only(benches, tmp_path, capsys):
    a = _run(tmp_path, capsys)
    SPEED.update(us=20.0, ms=4.2)  # per-step time x2, whole computation x1.05
    b = _run(tmp_path, capsys)
    result = compare_runs(a, b)
    verdicts = dict(zip(result.compared["variant"], result.compared["verdict"]))
    assert verdicts == {"one_step": "regression", "to_target": "ok"}
    assert result.compared["err_ratio"].isna().all()
    assert compare_runs(a, b, judge_time=False).regressions.empty
    SPEED.update(us=10.0, ms=8.0)  # the whole computation x2: judged on time_us
    c = _run(tmp_path, capsys)
    assert list(compare_runs(a, c).regressions["variant"]) == ["to_target"]


def test_bench_returning_an_exit_code_stores_nothing(benches, tmp_path):
    assert run_bench("exit_code", quick=True, out=tmp_path) == 3
    assert not any(tmp_path.iterdir())


# -- the built-in benches' figures -------------------------------------------------------------
def test_inhouse_figures_have_distinct_keys_and_honest_times():
    from refsim_benchmarks import inhouse
    rows = [("refsim rk4, dt = 0.005 s", 9e-9, 0.005, "rk4", 2),
            ("refsim dopri5_adaptive:1e-9", 4e-10, 0.04, "dopri5_adaptive:1e-9", 1)]
    scipy_row = ("scipy", 5e-9, 0.02, "DOP853", 3e-9)
    figures = check_figures(
        [inhouse.single_figure(2.0, 5000, 3), inhouse.batch_figure(2e7, 10_000, 50, 3),
         *inhouse.target_figures(rows, scipy_row, 3),
         *inhouse.box_figures([(100, 500.0), (1000, 4000.0)], 0.9, 20, 3)], "inhouse")
    by_name = {(f["figure"], f["integrator"]): f for f in figures}
    # 1e4 pendulums at 2e7 pendulum-steps/s: one batch step takes 5e-4 s
    assert by_name[("rk4_batch_10000_pendulums", "rk4")]["us_per_step"] == pytest.approx(500.0)
    rk4 = by_name[("time_to_1e-08", "rk4")]
    # dt_found = 0.01 / 2: halving is exact, so the double nearest 0.005, bit for bit
    assert rk4["steps"] == 2000 and rk4["dt_found"] == 0.005
    # time_us = t * 1e6 of t = 0.005 s (inexact in binary): within half an ulp of 5000 before
    # the product's own rounding adds another half
    assert_ulp(rk4["time_us"], 5000.0, 1, "0.005 s times 1e6: two half-ulp roundings")
    assert rk4["vs_solve_ivp"] == pytest.approx(0.25)
    assert by_name[("time_to_1e-08", "dopri5_adaptive:1e-9")]["steps"] == 0
    # 4000 us / 1000 spheres * 1e3: every step exact in binary (4.0, 4000.0)
    assert by_name[("contact_box_1000", "symplectic_euler")]["ns_per_sphere_step"] == 4000.0


def test_sph_throughput_is_fluid_particle_steps_per_second():
    """5000 fluid particles, 40 steps in 0.5 s: 4e5 particle-steps/s, 12.5 ms per step."""
    from refsim_benchmarks import sph
    fig = sph.throughput_figure(5000, "taichi", "cpu", 1e-4, 40, 0.5, 5000, 2)
    assert fig["value"] == pytest.approx(400_000.0)
    assert fig["us_per_step"] == pytest.approx(12_500.0)
    assert check_figures([fig], "sph")[0]["engine_variant"] == "cpu"


@pytest.mark.slow
def test_inhouse_bench_quick_is_a_stored_run(tmp_path, capsys):
    """The whole quick in-house bench (about 10 s): its printed figures and its stored rows."""
    assert cli.main(["bench", "--quick", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "1. RK4 on one pendulum" in out and "cost exponent" in out
    run = open_run("RUN", out.strip().splitlines()[-1])
    table = pd.DataFrame(run.rows.values())
    assert len(table) == len({row_key(r) for r in run.rows.values()}) >= 9
    assert set(table["status"]) == {"ok"} and (table["us_per_step"].notna()
                                               | table["time_us"].notna()).all()
    assert json.loads((run.dir / "manifest.json").read_text())["bench"] == "inhouse"
