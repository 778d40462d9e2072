"""The tolerance suite on a home-grown engine (tests/harness/example_engine.py): it passes on honest
physics, fails on a wrong stepper, and the plugin's marker gives the same tests."""
import pytest

from example_engine import PointMassEngine, PointMassSim
from refsim.testing import (accuracy, check, engine_suite, job_id, resolve_engine, suite,
                            suite_params)

# the two lines a user writes: every case x variant x integrator the engine supports
test_point_mass_engine = engine_suite(PointMassEngine)


@pytest.mark.refsim_engine(PointMassEngine(), cases=["free_fall"])
def test_marker_form_job_is_within_tolerance(refsim_job):
    assert (check(refsim_job)["consistency"] == "consistent")


class FirstOrderDriftSim(PointMassSim):
    """Claims velocity Verlet (order 2) but drifts with the old velocity, x += dt v, dropping
    the dt^2 a / 2 term: a first-order position update."""

    def velocity_verlet(self):
        self.x = self.x + self.dt * self.v
        a_new = self.accel(self.x, self.v)
        self.v = self.v + 0.5 * self.dt * (self.a + a_new)
        self.a = a_new


class FirstOrderDriftEngine(PointMassEngine):
    name = "example_first_order_drift"
    sim_class = FirstOrderDriftSim


def test_suite_covers_what_the_engine_supports():
    ids = [job_id(j) for j in suite(PointMassEngine)]
    assert "free_fall/default-symplectic_euler" in ids
    assert "stiff_spring/k=1e6-velocity_verlet" in ids
    # free_fall (no drag variant: no "drag"), the 5 default spring variants (k=1e2 runs by name)
    assert len(ids) == 2 * (1 + 5)
    assert not any(i.startswith(("pendulum", "sphere_pairs", "newtons_cradle", "sphere_box",
                                 "dam_break", "hydrostatic_tank")) for i in ids)
    assert all(j.dt == pytest.approx(1e-3) for j in suite(PointMassEngine, ["free_fall"]))


def test_a_wrong_stepper_fails_the_check():
    job, = [j for j in suite(FirstOrderDriftEngine, ["free_fall"])
            if j.integrator == "velocity_verlet"]
    with pytest.raises(AssertionError, match=r"inconsistent with its method: error .* above the method's bound"):
        check(job)


def test_engine_agrees_with_refsim_on_the_same_job():
    for case, variant, integrator in [("free_fall", "default", "symplectic_euler"),
                                      ("stiff_spring", "underdamped", "velocity_verlet")]:
        dt = 1e-3 if case == "free_fall" else 5e-4
        ours = accuracy(case, variant, resolve_engine(PointMassEngine), integrator, dt)
        ref = accuracy(case, variant, "refsim", integrator, dt)
        assert ours["err_max"] == pytest.approx(ref["err_max"], rel=1e-9, abs=1e-12)


def test_resolve_engine_takes_names_and_classes_and_refuses_impostors():
    assert resolve_engine("refsim") == "refsim"
    assert resolve_engine(PointMassEngine) == resolve_engine(PointMassEngine()) \
        == "example_point_mass"

    class Impostor(PointMassEngine):
        name = "refsim"

    with pytest.raises(ValueError, match="already registered"):
        resolve_engine(Impostor)
    with pytest.raises(ValueError, match="engine must be one of"):
        resolve_engine("no_such_engine")
    with pytest.raises(ValueError, match="engine must be a registered engine name"):
        resolve_engine(42)


def test_an_engine_with_no_supported_scene_is_one_skip():
    class GravityOnly2D(PointMassEngine):
        name = "example_2d_only"
        dims = (2,)

    param, = suite_params(GravityOnly2D)
    assert param.id == "no-jobs" and "supports none" in param.marks[0].kwargs["reason"]


def test_refsim_pytest_plugin_is_registered(pytestconfig):
    assert pytestconfig.pluginmanager.has_plugin("refsim")
