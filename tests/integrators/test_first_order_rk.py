"""First-order steppers (refsim.integrators.first_order): the Butcher tableaux run on p' = u,
their stability functions against the slides' closed forms, and their orders on a linear ODE."""
import numpy as np
import pytest

from refsim.integrators import INTEGRATORS
from refsim.integrators.first_order import FIRST_ORDER, get_first_order

NOMINAL = {"explicit_euler": 1, "midpoint": 2, "heun": 2, "rk2": 2, "rk4": 4,
           "implicit_euler": 1}
EPS = np.finfo(float).eps


class Decay:
    """p' = M p (M 3 x 3), the linear test system, on (n, 3) arrays."""

    linear = True

    def __init__(self, matrix):
        self.matrix = np.asarray(matrix, float)

    def velocity(self, t, p):
        return p @ self.matrix.T

    def jacobian(self, t, p):
        return self.matrix


def test_not_in_second_order_list_and_names():
    assert set(FIRST_ORDER).isdisjoint({"symplectic_euler", "stormer_verlet"})
    assert "explicit_euler" in INTEGRATORS  # the same names, a separate factory
    with pytest.raises(ValueError, match="first-order integrator must be one of"):
        get_first_order("velocity_verlet")
    with pytest.raises(ValueError, match="alpha"):
        get_first_order("rk2:x")
    assert get_first_order("rk2:0.5").name == "rk2:0.5"


@pytest.mark.parametrize("name", FIRST_ORDER)
def test_stability_closed_forms(name):
    """|R(iy)| as docs/models.md#fields-vortex-radius-per-step prints it (and 1/sqrt(1 + y^2)
    for implicit Euler); checked to a few eps: the polynomial is summed in floating point
    (<= 5 terms of size <= 1.1)."""
    y = np.linspace(0.0, 1.5, 31)
    closed = {"explicit_euler": np.sqrt(1 + y ** 2), "implicit_euler": 1 / np.sqrt(1 + y ** 2),
              "rk4": np.sqrt(1 - y ** 6 / 72 + y ** 8 / 576)}.get(name, np.sqrt(1 + y ** 4 / 4))
    got = np.abs(get_first_order(name).stability(1j * y))
    assert np.max(np.abs(got - closed)) <= 16 * EPS * np.max(closed)


@pytest.mark.parametrize("name", FIRST_ORDER)
def test_one_step_is_the_step_matrix(name):
    """One step on p' = M p is R(h M) p to round-off (3 x 3, entries <= 1, h |M| <= 0.6)."""
    rng = np.random.default_rng(3)
    matrix = rng.uniform(-1, 1, (3, 3))
    p = rng.uniform(-1, 1, (5, 3))
    stepper, h = get_first_order(name), 0.2
    got = stepper.step(Decay(matrix), 0.0, p, h)
    want = p @ stepper.step_matrix(matrix, h).T
    assert np.max(np.abs(got - want)) <= 64 * EPS


@pytest.mark.parametrize("name", FIRST_ORDER)
def test_orders_on_a_linear_ode(name):
    """Global error at t = 1 against expm: slope between h = 0.02 and 0.01 within 0.1 of the
    nominal order (the next term is O(h) relative: 0.01-0.02 of it here)."""
    from scipy.linalg import expm
    matrix = np.array([[-0.5, 1.0, 0.0], [-1.0, -0.5, 0.2], [0.0, 0.3, -1.0]])
    p0 = np.array([[1.0, 0.5, -0.3]])
    exact = p0 @ expm(matrix).T
    stepper, errors = get_first_order(name), []
    for n in (50, 100):
        _, p = stepper.advance(Decay(matrix), 0.0, p0, 1.0 / n, n)
        errors.append(np.max(np.abs(p - exact)))
    assert abs(np.log2(errors[0] / errors[1]) - NOMINAL[name]) < 0.1


def test_batch_axes_and_implicit_needs_linear():
    """A leading batch axis runs each member as alone (bit for bit: the same arithmetic)."""
    matrix = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -0.2]])
    p = np.random.default_rng(1).normal(size=(2, 4, 3))
    for name in FIRST_ORDER:
        stepper = get_first_order(name)
        batch = stepper.step(Decay(matrix), 0.0, p, 0.1)
        alone = np.stack([stepper.step(Decay(matrix), 0.0, q, 0.1) for q in p])
        assert np.allclose(batch, alone, rtol=0, atol=4 * EPS)

    class Curved(Decay):
        linear = False
    with pytest.raises(ValueError, match="affine"):
        get_first_order("implicit_euler").step(Curved(matrix), 0.0, p[0], 0.1)
