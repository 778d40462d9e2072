"""`refsim bench sleeping_top`: the linearised criterion it compares against, the quick sweep's
plan, refsim's and MuJoCo's RK4 thresholds against the theory within the bench's derived bound,
and the figures stored as a run."""
import math

import numpy as np
import pytest

from refsim_benchmarks import sleeping_top as bench
from refsim import cli, registry
from refsim.store.figures import check_figures
from refsim.registry import get_engine
from refsim.store.results import load_results


def test_linear_criterion_lies_between_one_and_the_stable_peak_bound():
    r_exact = bench.linear_threshold(bench.exact_times())
    # r = 1 falls (the tilt ratio |1 - i Omega_c t| passes 10 at Omega_c t = 10 < 6 pi) and a
    # stable top peaks at r / sqrt(r^2 - 1) times its start: 10 at r = 10 / sqrt(99)
    peak_bound = bench.FACTOR / math.sqrt(bench.FACTOR ** 2 - 1)
    assert 1.0 <= r_exact <= peak_bound + bench.LINEAR_RESOLUTION
    # looks every quarter radian see at most the exact-time maximum: the engine's criterion
    # can only be as strict or laxer, so its threshold is at or below the exact-time one
    for dt in bench.DTS:
        assert bench.linear_threshold(bench.look_times(dt)) <= r_exact + bench.LINEAR_RESOLUTION


def test_quick_plan_is_fixed_step_and_names_every_engine():
    plan, skipped = bench.sweep_plan(quick=True)
    planned = {engine for engine, *_ in plan}
    assert planned.isdisjoint(name for name, _ in skipped)
    assert planned | {name for name, _ in skipped} == set(bench.ENGINES)
    assert ("refsim", "quat_exp", "rk4", 1e-2) in plan
    assert all(not integrator.partition(":")[0].endswith("_adaptive")
               for _, _, integrator, _ in plan)
    assert all(reason for _, reason in skipped)


@pytest.mark.parametrize("engine,variant", [("refsim", "quat_exp"), ("mujoco", "")])
def test_rk4_threshold_agrees_with_the_theory(engine, variant):
    if not get_engine(engine).available():
        pytest.skip(f"{engine} not installed")
    fig = bench.threshold_figure(engine, variant, "rk4", 1e-2)
    # the bound (bench docstring): resolution / 2 + (factor tilt)^2 + (w3c dt)^4 + 1e-6
    assert fig["order"] == 4
    assert fig["bound"] == pytest.approx(5e-4 + 1e-4 + (7.672 * 1e-2) ** 4 + 1e-6, rel=1e-3)
    assert abs(fig["value"] - fig["linear_threshold"]) <= fig["bound"]
    assert fig["agrees"] is True
    assert abs(fig["value"] - 1.0) <= 0.005 + fig["bound"]  # theory's 1, criterion's offset


def test_bench_stores_its_figures(tmp_path, capsys, monkeypatch):
    if not get_engine("mujoco").available():
        pytest.skip("mujoco not installed")
    monkeypatch.setattr(bench, "sweep_plan", lambda quick: (
        [("mujoco", "", "rk4", 1e-2), ("mujoco", "", "implicit", 1e-2)],
        [("taichi", "no pivots")]))
    # installed by pyproject's entry point; registered here only when running from a tree
    # whose metadata predates it
    installed = "sleeping_top" in registry.entries("bench")
    if not installed:
        registry.register("bench", "sleeping_top", "refsim_benchmarks.sleeping_top:main")
    try:
        assert cli.main(["bench", "sleeping_top", "--quick", "--out", str(tmp_path)]) == 0
    finally:
        if not installed:
            registry.unregister("bench", "sleeping_top")
    out = capsys.readouterr().out
    assert "taichi: unsupported: no pivots" in out
    results = load_results(out.strip().splitlines()[-1])
    assert sorted(results["integrator"]) == ["implicit", "rk4"]
    assert np.all(results["units"] == bench.UNITS)
    assert np.all(np.isfinite(results["value"].astype(float)))
    assert set(results["case"]) == {"bench:sleeping_top"}


def test_figures_pass_the_store_check_and_bad_dt_is_refused():
    fig = {"figure": "sleeping_threshold", "value": 1.0, "units": bench.UNITS,
           "description": "d", "engine": "refsim", "integrator": "rk4", "dt": 1e-2}
    assert check_figures([fig], "sleeping_top") == [fig]
    with pytest.raises(ValueError, match="dt must be a finite number > 0"):
        bench.look_times(0.0)
