"""A batch of N independent instances advanced together equals N separate runs."""
import numpy as np
import pytest

from refsim.integrators import INTEGRATORS, get_integrator
from refsim.models.joints import HingeSystem, RodSet
from refsim.models.system import ParticleSystem

G_OVER_L = 9.81
THETA0 = np.linspace(0.2, 3.0, 16)


def _run(stepper, system, x0, v0, h=0.01, n=200):
    state = stepper.start(system, 0.0, x0, v0, h)
    _, state = stepper.advance(system, 0.0, state, h, n)
    return stepper.output(system, n * h, state, h)


# the adaptive stepper is left out by design: one error norm sets one step for the whole batch
@pytest.mark.parametrize("name", [n for n in INTEGRATORS if n != "dopri5_adaptive"])
def test_pendulum_batch_equals_separate_runs(name):
    stepper = get_integrator(name)
    batch = _run(stepper, HingeSystem(np.array([G_OVER_L]), np.array([0.0])),
                 THETA0[:, None], np.zeros((len(THETA0), 1)))
    for i, th in enumerate(THETA0):
        single = _run(stepper, HingeSystem(np.float64(G_OVER_L), np.float64(0.0)),
                      np.float64(th), np.float64(0.0))
        # same operations in the same order; numpy's vectorised sin may differ from the
        # scalar one in the last bit, hence a few ulps rather than bitwise equality
        assert abs(batch[0][i, 0] - single[0]) <= 4e-15 * max(1.0, abs(single[0]))
        assert abs(batch[1][i, 0] - single[1]) <= 4e-14 * max(1.0, abs(single[1]))


@pytest.mark.parametrize("name", ["symplectic_euler", "rk4", "implicit_euler"])
def test_kkt_batch_equals_separate_runs(name):
    stepper = get_integrator(name)
    rods = RodSet(np.array([0]), np.zeros((1, 3)), np.array([1.0]), baumgarte=15.0)
    system = ParticleSystem(np.array([1.0]), (0.0, 0.0, -9.81), rods=rods)
    x0 = np.stack([np.sin(THETA0), np.zeros_like(THETA0), -np.cos(THETA0)], axis=1)
    v0 = np.zeros_like(x0)
    bx, bv = _run(stepper, system, x0, v0, n=50)
    for i in range(len(THETA0)):
        sx, sv = _run(stepper, system, x0[i], v0[i], n=50)
        np.testing.assert_allclose(bx[i], sx, rtol=0, atol=1e-13)
        np.testing.assert_allclose(bv[i], sv, rtol=0, atol=1e-12)
