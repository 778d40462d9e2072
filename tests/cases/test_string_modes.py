"""string_modes: the normal-mode frequencies are the in-house model's eigenvalues; every
stepper follows its closed-form discrete mode to round-off; Baraff-Witkin's amplitude factor
(1 + y^2)^(-1/2) and phase arctan(y) per step hold to round-off (its numerical damping,
measured); orders in dt; the explicit limits on the stiffest mode (half the one-spring value)
measured by `refsim stress --case string_modes`."""
import math

import numpy as np
import pytest

from refsim_cases.spring_network._linear_steps import backward_euler_factor, mode_amplitude
from refsim_cases.spring_network.string_modes import CASE
from refsim.models.spring_network import NetworkSystem
from refsim.registry import get_engine
from refsim.run.job import Job, run_job
from refsim.scene import SpringNetwork

ENGINE = get_engine("refsim")
EPS = np.finfo(float).eps
STEPPERS = ["symplectic_euler", "velocity_verlet", "rk4", "baraff_witkin"]


def _run(p, integrator, dt, steps):
    sim = ENGINE.build(CASE.scene(p), dt, integrator, "")
    sim.step(steps)
    return sim.observe()


@pytest.mark.parametrize("variant", ["default", "membrane"])
def test_mode_frequency_is_an_eigenvalue_of_the_in_house_model(variant):
    p = CASE.variant_params(variant)
    scene = CASE.scene(p)
    system = NetworkSystem(scene.part(SpringNetwork), scene.gravity)
    x = scene.part(SpringNetwork).positions[system.free].reshape(-1)
    a, _ = system.jacobians(0.0, x, np.zeros_like(x))
    phi = np.zeros((len(system.free), 3))
    phi[:, 2] = CASE.grid(p)[2]
    phi = phi[system.free].reshape(-1)
    # the Jacobian of zero rest-length springs is -k/m times a graph Laplacian, exactly
    # (entries k/m rounded once): relative round-off of a few eps of w^2
    assert np.allclose(a @ phi, -CASE.omega(p) ** 2 * phi, rtol=0,
                       atol=16 * EPS * CASE.omega_max(p) ** 2)


@pytest.mark.parametrize("variant", ["default", "membrane"])
@pytest.mark.parametrize("integrator", STEPPERS)
def test_each_stepper_is_its_closed_form_discrete_mode(variant, integrator):
    p = CASE.variant_params(variant)
    dt, steps = CASE.dts(p)[0], 60
    o = _run(p, integrator, dt, steps)
    expected = CASE.rest_positions(p)
    expected[:, 2] = p["amplitude"] * CASE.grid(p)[2] * \
        mode_amplitude(integrator, CASE.omega(p), dt, [steps])[0]
    err = np.max(np.linalg.norm(o["x"] - expected, axis=1))
    tol, _ = CASE._roundoff(p, steps)  # the case's stated round-off bound (Henrici)
    assert err <= tol


def test_baraff_witkin_amplitude_and_phase_per_step_to_round_off():
    """Backward Euler's step on the mode is normal in (q, q'/w): |(q, q'/w)| falls by exactly
    (1 + y^2)^(-1/2) a step and turns by arctan(y)."""
    p = CASE.variant_params("default")
    dt, steps = CASE.dts(p)[0], 100
    w = CASE.omega(p)
    obs = {k: np.asarray(v)[None] for k, v in _run(p, "baraff_witkin", dt, steps).items()}
    o = CASE.observables(p, obs)
    q, rate = o["amplitude"][0] / p["amplitude"], o["amplitude_rate"][0] / (w * p["amplitude"])
    factor, phase = backward_euler_factor(w * dt)
    # round-off: the case's bound over the amplitude A (relative)
    tol = CASE._roundoff(p, steps)[0] / p["amplitude"]
    assert math.hypot(q, rate) == pytest.approx(factor ** steps, abs=tol)
    assert math.atan2(-rate, q) == pytest.approx(
        math.remainder(steps * phase, 2 * math.pi), abs=tol / factor ** steps)
    assert factor ** steps < 0.9  # a measurable damping, not round-off


def test_baraff_witkin_damping_per_period_is_the_run_metric():
    p = CASE.variant_params("default")
    dt = CASE.reference_dt(p)
    row = run_job(Job("string_modes", "default", "refsim", "", "baraff_witkin", dt), repeats=0)
    steps = row["steps"]
    factor, _ = backward_euler_factor(CASE.omega(p) * dt)
    per_period = factor ** (steps * CASE.period(p) / (steps * dt))
    assert row["amplitude_per_period"] == pytest.approx(per_period, rel=1e-9)
    assert (row["consistency"] == "consistent")


@pytest.mark.parametrize("integrator,order", [("symplectic_euler", 1), ("velocity_verlet", 2),
                                              ("rk4", 4), ("baraff_witkin", 1)])
def test_error_has_the_stepper_order(integrator, order):
    p = CASE.variant_params("default")
    dts = CASE.dts(p) + CASE.order_dts(p)
    dts = dts + [dts[-1] / 2]  # a third point: two slopes
    err = [run_job(Job("string_modes", "default", "refsim", "", integrator, dt),
                   repeats=0)["err_max"] for dt in dts]
    slopes = np.diff(np.log(err)) / np.diff(np.log(dts))
    # y1 = w1 dt <= 0.05: the leading error term dominates the next by ~y1 (<= 5 %)
    assert np.all(np.abs(slopes - order) < 0.1), slopes


def test_mode_beyond_the_nodes_names_the_parameter():
    with pytest.raises(ValueError, match="mode"):
        CASE.scene(CASE.validate({"mode": 16}))


def test_stiffest_mode_halves_the_one_spring_limit():
    p = CASE.variant_params("default")
    n = p["nodes"]
    assert CASE.stiffest_factor(p) == pytest.approx(2 * math.sin(n * math.pi / (2 * (n + 1))),
                                                    rel=1e-14)
    assert CASE.stiffest_factor(CASE.validate({"nodes": 400})) == pytest.approx(2, rel=1e-4)


@pytest.mark.slow
def test_stress_measures_the_explicit_limits_on_the_stiffest_mode(stress_limits):
    """~30 s: one Sim per y (a network is not a one-body batch)."""
    table = stress_limits("string_modes", "default", STEPPERS)
    factor = CASE.stiffest_factor(CASE.variant_params("default"))
    assert table.loc["velocity_verlet", "theory"] == pytest.approx(2 / factor, rel=1e-12)
    assert table.loc["rk4", "theory"] == pytest.approx(2 * math.sqrt(2) / factor, rel=1e-9)
    for name in STEPPERS[:3]:
        assert table.loc[name, "agrees"], name
    for name in STEPPERS[:2]:  # about half slide 001's one-spring 2 sqrt(m/k): 2 / 1.99
        assert 1.0 < table.loc[name, "measured"] < 1.01
    assert math.isinf(table.loc["baraff_witkin", "measured"])
