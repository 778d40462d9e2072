"""The in-house sims on the Engine/Sim base contract: time as steps x dt, n validated, a
stepper's breakdown captured as `failure` with the time it happened, build validation first."""
import numpy as np
import pytest

from refsim.registry import get_case, get_engine


def _stiff_spring_sim(integrator="dopri5_adaptive"):
    case = get_case("stiff_spring")
    p = case.validate()
    dt = case.dts(p)[0]
    return get_engine("refsim").build(case.scene(p), dt, integrator), dt


def test_observed_time_is_steps_times_dt():
    sim, dt = _stiff_spring_sim("rk4")
    sim.step(7)
    sim.step(0)
    sim.step(3)
    assert sim.steps == 10 and sim.observe()["t"] == 10 * dt


def test_negative_step_count_is_refused():
    sim, _ = _stiff_spring_sim("rk4")
    with pytest.raises(ValueError, match="n must be >= 0"):
        sim.step(-1)


def test_stepper_failure_becomes_failure_and_stops_stepping():
    sim, dt = _stiff_spring_sim()
    sim.step(10)
    sim.system.accel = lambda t, x, v: np.full_like(x, np.nan)  # a breakdown mid-run
    sim.step(5)
    assert sim.failure == f"dopri5_adaptive: non-finite error estimate at t={10 * dt:.6g}"
    sim.step(5)
    assert sim.steps == 10 and sim.observe()["t"] == 10 * dt


@pytest.mark.parametrize("case_name, variant", [("pendulum", "nope"),
                                                ("sphere_pairs", "generalized")])
def test_build_refuses_a_variant_the_scene_has_not(case_name, variant):
    case = get_case(case_name)
    p = case.validate()
    with pytest.raises(ValueError, match="refsim formulation must be one of"):
        get_engine("refsim").build(case.scene(p), case.dts(p)[0], "symplectic_euler", variant)


def test_fluid_scene_refuses_other_integrators_before_building():
    case = get_case("dam_break")
    p = case.validate()
    with pytest.raises(ValueError, match="kick-drift-kick SPH"):
        get_engine("refsim").build(case.scene(p), case.dts(p)[0], "rk4")
