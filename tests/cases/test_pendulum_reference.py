"""The exact Jacobi-elliptic pendulum against scipy's DOP853 and the known periods."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from refsim_cases.particles.pendulum import exact_pendulum, period


@pytest.mark.parametrize("theta0", [0.3, 1.0, np.pi / 2, 2.5, 3.0])
def test_exact_solution_matches_dop853(theta0):
    w0 = np.sqrt(9.81)
    t = np.linspace(0.0, 10.0, 1001)
    sol = solve_ivp(lambda _, y: [y[1], -w0 * w0 * np.sin(y[0])], (0.0, 10.0), [theta0, 0.0],
                    method="DOP853", rtol=1e-12, atol=1e-14, t_eval=t)
    theta, theta_dot = exact_pendulum(theta0, w0, t)
    assert np.max(np.abs(theta - sol.y[0])) < 1e-9
    assert np.max(np.abs(theta_dot - sol.y[1])) < 1e-9 * w0


@pytest.mark.parametrize("theta0,expected", [(1.0, 1.066334245579963),
                                             (np.pi / 2, 1.1803405990160962),
                                             (3.0, 2.571233949432141)])
def test_period_over_the_small_swing_period_is_the_known_ratio(theta0, expected):
    w0 = 2.0
    assert period(theta0, w0) * w0 / (2 * np.pi) == pytest.approx(expected, rel=1e-12)


def test_exact_swing_starts_at_rest_and_reaches_minus_theta0_at_half_period():
    w0 = np.sqrt(9.81)
    theta, theta_dot = exact_pendulum(1.0, w0, np.array([0.0, period(1.0, w0) / 2]))
    np.testing.assert_allclose(theta, [1.0, -1.0], atol=1e-13)
    np.testing.assert_allclose(theta_dot, [0.0, 0.0], atol=1e-12)
