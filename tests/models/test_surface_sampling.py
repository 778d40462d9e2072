"""refsim.models.surface_sampling: gradient, projection, polyhedra and the descent."""
import numpy as np
import pytest

from refsim.integrators.first_order import get_first_order
from refsim.models.surface_sampling import (POLYHEDRA, SphereSampling, polyhedron_angle_error,
                                            polyhedron_vertices, relaxation_rates)
from refsim.scene.surface_sampling import SurfaceSampling

EPS = np.finfo(float).eps


def test_part_validation():
    with pytest.raises(ValueError, match="surface_sampling.sigma"):
        SurfaceSampling(sigma=0.0)
    with pytest.raises(ValueError, match="surface_sampling.alpha"):
        SurfaceSampling(alpha=-1.0)


def test_gradient_against_central_differences():
    """grad_{p_i} E_i against differences of E_i = 2 sum_j E_ij (step 1e-6: truncation
    ~1e-12, round-off ~eps/1e-6 ~ 2e-10 relative)."""
    system = SphereSampling(1.0, (0, 0, 0), 0.6, 1.3)
    p = system.project(np.random.default_rng(5).normal(size=(5, 3)))

    def own_energy(q, i):
        pair, _ = system.pair_terms(q)
        return 2.0 * (np.sum(pair[i]) - system.alpha)
    step, grad = 1e-6, system.gradient(p)
    for i in range(5):
        for k in range(3):
            d = np.zeros_like(p)
            d[i, k] = step
            fd = (own_energy(p + d, i) - own_energy(p - d, i)) / (2 * step)
            assert abs(fd - grad[i, k]) <= 1e-8


@pytest.mark.parametrize("n", sorted(POLYHEDRA))
def test_polyhedra_are_fixed_points(n):
    system = SphereSampling(1.0, (0, 0, 0), 0.6, 1.0)
    vertices = polyhedron_vertices(n)
    assert polyhedron_angle_error(vertices, np.zeros(3)) <= 1e-12
    assert np.max(np.abs(system.velocity(0.0, vertices))) <= 64 * EPS * n
    rates = relaxation_rates(system, vertices)
    assert np.sum(np.abs(rates) < 1e-6 * np.max(np.abs(rates))) == 3  # rigid rotations
    assert np.all(rates[np.abs(rates) >= 1e-6 * np.max(np.abs(rates))] < 0)  # a minimum


@pytest.mark.parametrize("n,sigma", [(4, 0.7), (6, 0.7), (12, 0.5)])
def test_descent_reaches_the_polyhedron_and_energy_falls(n, sigma):
    system = SphereSampling(1.0, (0, 0, 0), sigma, 1.0)
    p = system.project(np.random.default_rng(14).normal(size=(n, 3)))
    stepper, energies = get_first_order("explicit_euler"), [system.energy(p)]
    for _ in range(40):
        _, p = stepper.advance(system, 0.0, p, 0.05, 20)
        energies.append(system.energy(p))
    assert np.max(np.diff(energies)) <= 4 * EPS * energies[0]
    assert polyhedron_angle_error(p, np.zeros(3)) < 1e-6
    assert np.max(np.abs(np.linalg.norm(p, axis=1) - 1.0)) <= 4 * EPS
