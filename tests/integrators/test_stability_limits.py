"""Stability theory on the undamped oscillator x'' = -w^2 x, y = w dt
(docs/engine_notes.md#exact-oscillator-stability-limits)."""
import numpy as np
import pytest

from refsim.integrators import get_integrator
from refsim.run.metrics import bisect_limit, step_map_stable
from refsim.models.system import LinearSystem

LIMITS = {  # largest stable y from theory
    "symplectic_euler": 2.0, "symplectic_euler_dk": 2.0, "stormer_verlet": 2.0,
    "velocity_verlet": 2.0, "leapfrog": 2.0, "rk4": 2.0 * np.sqrt(2.0),
    "dopri5": 0.99719,  # |R(iy)| of the 5th-order Dormand-Prince weights, quoted to 5 digits
}


@pytest.mark.parametrize("name", LIMITS)
def test_bisected_stability_limit_matches_theory(name):
    stepper = get_integrator(name)
    limit = bisect_limit(lambda y: step_map_stable(stepper, y), 0.05, 4.0, tol=1e-9)
    digits = 5e-6 if name == "dopri5" else 1e-8  # the quoted value's last digit
    assert limit == pytest.approx(LIMITS[name], abs=digits)


@pytest.mark.parametrize("name", ["implicit_euler", "baraff_witkin"])
def test_implicit_steppers_are_stable_at_every_step_size(name):
    stepper = get_integrator(name)
    assert all(step_map_stable(stepper, y) for y in (0.1, 1.0, 10.0, 1e3))


@pytest.mark.parametrize("name", ["explicit_euler", "midpoint", "heun", "rk2"])
def test_euler_and_two_stage_rk_are_unstable_at_every_step_size(name):
    stepper = get_integrator(name)
    assert not any(step_map_stable(stepper, y, slack=0.0) for y in (1e-2, 0.1, 1.0))


def _energy_ratio(name, y, x=0.7, v=-0.4):
    """E(after one step) / E(before) on x'' = -x (w = 1, h = y)."""
    system = LinearSystem([[1.0]])
    stepper = get_integrator(name)
    state = stepper.start(system, 0.0, np.array([x]), np.array([v]), y)
    state = stepper.step(system, 0.0, state, y)
    x1, v1 = stepper.output(system, y, state, y)
    return (x1[0] ** 2 + v1[0] ** 2) / (x * x + v * v)


@pytest.mark.parametrize("y", [0.01, 0.1, 0.5, 1.5])
def test_one_step_energy_ratio_is_each_methods_closed_form(y):
    assert _energy_ratio("explicit_euler", y) == pytest.approx(1 + y * y, rel=1e-13)
    assert _energy_ratio("implicit_euler", y) == pytest.approx(1 / (1 + y * y), rel=1e-13)
    for name in ("midpoint", "heun", "rk2"):
        assert _energy_ratio(name, y) == pytest.approx(1 + y ** 4 / 4, rel=1e-13)


@pytest.mark.parametrize("name", ["stormer_verlet", "velocity_verlet", "leapfrog"])
@pytest.mark.parametrize("y", [0.05, 0.5, 1.9])
def test_verlet_from_rest_is_exact_discrete_cosine(name, y):
    system = LinearSystem([[1.0]])
    stepper = get_integrator(name)
    x0, n = 0.8, 400
    theta = 2 * np.arcsin(y / 2)
    state = stepper.start(system, 0.0, np.array([x0]), np.array([0.0]), y)
    xs = []
    for k in range(n):
        state = stepper.step(system, k * y, state, y)
        xs.append(stepper.output(system, (k + 1) * y, state, y)[0][0])
    expected = x0 * np.cos(theta * np.arange(1, n + 1))
    np.testing.assert_allclose(xs, expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("k,h,behaviour", [
    (10.0, 0.05, "monotone"), (10.0, 0.099, "monotone"),
    (10.0, 0.15, "oscillating decay"), (10.0, 0.19, "oscillating decay"),
    (10.0, 0.21, "growth"), (10.0, 0.5, "growth")])
def test_explicit_euler_decay_is_one_minus_hk_to_the_n_in_each_regime(k, h, behaviour):
    """y' = -k y under explicit Euler is the velocity of x'' = -k x' (a = -k v)."""
    system = LinearSystem([[0.0]], [[k]])
    stepper = get_integrator("explicit_euler")
    state = (np.zeros(1), np.ones(1))
    ys = [1.0]
    for n in range(30):
        state = stepper.step(system, n * h, state, h)
        ys.append(state[1][0])
    ys = np.array(ys)
    np.testing.assert_allclose(ys, (1 - h * k) ** np.arange(31), rtol=1e-12)
    if behaviour == "monotone":
        assert np.all(np.diff(ys) < 0) and np.all(ys > 0)
    elif behaviour == "oscillating decay":
        assert np.all(ys[1:] * ys[:-1] < 0) and np.all(np.diff(np.abs(ys)) < 0)
    else:
        assert np.all(ys[1:] * ys[:-1] < 0) and np.all(np.diff(np.abs(ys)) > 0)
