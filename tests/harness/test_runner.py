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
