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
    # same operations per instance: n = 4 takes the dense path, its einsums over the same axes
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


def _dense_formula(x, masses, G, softening):
    """The law as first written: dense (..., n, n, 3) separations, r^2 ** -1.5."""
    d = x[..., None, :, :] - x[..., :, None, :]
    r2 = np.einsum("...k,...k->...", d, d) + softening ** 2
    n = x.shape[-2]
    r2[..., np.arange(n), np.arange(n)] = np.inf
    return G * np.einsum("...ij,...ijk->...ik", r2 ** -1.5 * masses, d)


@pytest.mark.parametrize("shape", [(2, 3), (4, 2, 3), (3, 3), (2, 5, 3), (32, 3)])
def test_few_body_paths_are_the_dense_formula_to_round_off(shape):
    """n = 2 (Python floats, or numpy for a batch) and n <= DENSE_MAX_BODIES agree with the
    dense formula to round-off. Not bit for bit: they are not the same operations in the same
    order, and numpy's SIMD loops round differently per CPU (a 1-ulp difference measured on
    an AVX-512 Xeon, none on an EPYC). Each term G m_j d / s^3 rounds to <= 12 eps of itself
    (see the blocked path's test below) in either formula and the sum of n - 1 terms adds
    (n - 1) eps of sum |term|: |a - a_dense| <= 2 (n + 12) eps G sum_j m_j |d| / s^3."""
    eps = np.finfo(float).eps
    for trial in range(50):
        x = RNG.normal(size=shape) * RNG.uniform(0.01, 100.0)
        masses = RNG.uniform(0.1, 3.0, shape[-2])
        G, softening = (1.0, 0.0) if trial % 2 else (6.674e-11, 0.1)
        got = pair_accelerations(x, masses, G, softening)
        d = x[..., None, :, :] - x[..., :, None, :]
        r2 = np.einsum("...k,...k->...", d, d) + softening ** 2
        n = shape[-2]
        r2[..., np.arange(n), np.arange(n)] = np.inf
        scale = G * np.einsum("...ij,...ijk->...ik", r2 ** -1.5 * masses, np.abs(d))
        bound = 2 * (n + 12) * eps * scale
        assert np.all(np.abs(got - _dense_formula(x, masses, G, softening)) <= bound)


@pytest.mark.parametrize("offset, softening", [(0.0, 0.0), (1e3, 0.05)])
def test_blocked_path_is_within_round_off_of_the_exact_sum(offset, softening):
    """n > DENSE_MAX_BODIES: per-axis separations, w = m_j / (r^2 sqrt r^2), row dots. Each
    term w d rounds to <= 12 eps of itself (d: 1, r^2: 4, sqrt: 3, product: 8, quotient: 9,
    times d: 11, times G: 12), and the sum of n - 1 terms adds (n - 1) eps of sum |term|:
    |a - a_exact| <= (n + 12) eps G sum_j m_j |d| / s^3 per component (extended precision
    gives a_exact). A cluster far from the origin (offset 10^3) loses nothing: only
    differences x_j - x_i enter."""
    n = 150
    x = RNG.normal(size=(2, n, 3)) + offset
    masses = RNG.uniform(0.5, 1.5, n)
    got = pair_accelerations(x, masses, 1.3, softening, block_rows=7)  # 22 blocks, a remainder
    xl, ml = x.astype(np.longdouble), masses.astype(np.longdouble)
    d = xl[..., None, :, :] - xl[..., :, None, :]
    s2 = np.sum(d * d, axis=-1) + np.longdouble(softening) ** 2
    s2[..., np.arange(n), np.arange(n)] = np.inf
    terms = (ml / (s2 * np.sqrt(s2)))[..., None] * d * np.longdouble(1.3)
    exact, size = terms.sum(axis=-2), np.abs(terms).sum(axis=-2)
    excess = np.abs(got - exact.astype(float)) / ((n + 12) * np.finfo(float).eps * size)
    assert float(np.max(excess)) <= 1.0


def test_blocked_path_ignores_block_size_and_batching():
    """Every row is summed by the same row dot whatever the block: results bit for bit
    independent of block_rows and of the batch axes."""
    x = RNG.normal(size=(3, 40, 3))
    masses = RNG.uniform(0.5, 1.5, 40)
    whole = pair_accelerations(x, masses, 1.0, 0.01)
    for rows in (1, 7, 40):
        np.testing.assert_array_equal(pair_accelerations(x, masses, 1.0, 0.01, rows), whole)
    for k in range(3):
        np.testing.assert_array_equal(pair_accelerations(x[k], masses, 1.0, 0.01), whole[k])
