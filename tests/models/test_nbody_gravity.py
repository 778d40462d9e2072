"""GravitySystem and the invariants of refsim.models.nbody_gravity."""
import numpy as np
import pytest

from refsim.models.nbody_gravity import (
    GravitySystem,
    angular_momentum,
    pair_accelerations,
    pair_jacobian,
    runge_lenz,
    total_energy,
    total_momentum,
)
from refsim.models.system import finite_difference_jacobians

RNG = np.random.default_rng(14)


def test_jacobian_matches_central_differences():
    x = RNG.normal(size=(2, 5, 3))
    masses = RNG.uniform(0.5, 2.0, 5)
    system = GravitySystem(masses, G=1.3, softening=0.1)
    flat = x.reshape(2, 15)
    jx, jv = system.jacobians(0.0, flat, flat)
    fx, _ = finite_difference_jacobians(system.accel, 0.0, flat, np.zeros_like(flat))
    # central differences at step 1e-6 |x|: truncation ~ step^2 |a'''| ~ 1e-12 |a'''|, and
    # round-off eps |a| / step ~ 2e-10 |a|: both far below 1e-7 of the entries
    assert np.max(np.abs(jx - fx)) <= 1e-7 * np.max(np.abs(jx))
    assert not np.any(jv)


def test_batch_axes_equal_single_evaluations():
    x = RNG.normal(size=(3, 4, 3))
    masses = RNG.uniform(0.5, 2.0, 4)
    system = GravitySystem(masses)
    batched = system.accel(0.0, x.reshape(3, 12), None)
    single = np.array([system.accel(0.0, xi.reshape(12), None) for xi in x])
    np.testing.assert_array_equal(batched, single)


def test_pair_forces_are_equal_and_opposite():
    x = RNG.normal(size=(6, 3))
    masses = RNG.uniform(0.5, 2.0, 6)
    a = pair_accelerations(x, masses)
    # sum m a = 0 exactly in exact arithmetic; each of the n^2 terms rounds to eps |m a|
    assert np.linalg.norm(masses @ a) <= 36 * np.finfo(float).eps * np.sum(
        masses[:, None] * np.abs(a))


def test_energy_and_invariants_of_a_circular_orbit():
    masses = np.array([0.75, 0.25])
    x = np.array([[-0.25, 0.0, 0.0], [0.75, 0.0, 0.0]])  # separation 1, centre of mass 0
    v = np.array([[0.0, -0.25, 0.0], [0.0, 0.75, 0.0]])  # relative speed 1 = sqrt(G M / r)
    assert total_energy(x, v, masses) == pytest.approx(-0.5 * 0.75 * 0.25, rel=1e-15)
    np.testing.assert_allclose(total_momentum(v, masses), 0.0, atol=1e-17)
    np.testing.assert_allclose(angular_momentum(x, v, masses), [0, 0, 0.75 * 0.25], rtol=1e-15)
    np.testing.assert_allclose(runge_lenz(x, v, masses), 0.0, atol=1e-15)  # e = 0


def test_runge_lenz_points_to_periapsis_with_length_e():
    masses = np.array([1.0, 1e-3])
    e, rp = 0.6, 0.4
    speed = np.sqrt(np.sum(masses) * (1 + e) / rp)
    x = np.array([[0.0, 0.0, 0.0], [rp, 0.0, 0.0]])
    v = np.array([[0.0, 0.0, 0.0], [0.0, speed, 0.0]])
    np.testing.assert_allclose(runge_lenz(x, v, masses), [e, 0.0, 0.0], atol=1e-15)
    with pytest.raises(ValueError, match="2 bodies"):
        runge_lenz(np.zeros((3, 3)), np.zeros((3, 3)), np.ones(3))


def test_pair_jacobian_shape_and_row_sums():
    x = RNG.normal(size=(4, 3))
    jac = pair_jacobian(x, np.ones(4))
    assert jac.shape == (12, 12)
    # translation invariance: moving every body by the same vector leaves a unchanged
    np.testing.assert_allclose(jac.reshape(12, 4, 3).sum(axis=1), 0.0,
                               atol=1e-13 * np.max(np.abs(jac)))
