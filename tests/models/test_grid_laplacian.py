"""The grid Laplacian: its slices and its sparse matrix are the same operator, the Fourier
modes of each boundary kind are its eigenvectors with the stated eigenvalues, Dirichlet points
do not move."""
import itertools

import numpy as np
import pytest

from refsim_cases.grid_evolution._modes import ModeGrid
from refsim.models.grid_laplacian import GridLaplacian

SIDES = [("dirichlet", "dirichlet"), ("neumann", "neumann"), ("periodic", "periodic"),
         ("dirichlet", "neumann")]


@pytest.mark.parametrize("shape", [(7,), (5, 6), (4, 5, 6)])
def test_slices_equal_the_sparse_matrix_for_every_boundary_combination(shape):
    rng = np.random.default_rng(3)
    for combo in itertools.product(SIDES, repeat=len(shape)):
        lap = GridLaplacian(shape, [0.1 * (a + 1) for a in range(len(shape))], combo)
        u = rng.standard_normal(shape)
        by_slices = lap.apply(u)
        by_matrix = (lap.matrix() @ u.reshape(-1)).reshape(shape)
        # the same terms summed in another order: a few eps of the largest term 4|u|/h^2
        assert np.max(np.abs(by_slices - by_matrix)) <= 16 * np.finfo(float).eps * \
            np.max(np.abs(u)) * 4 / 0.01, combo
        assert np.all(by_slices[~lap.free] == 0.0)


@pytest.mark.parametrize("boundary", ["dirichlet", "neumann", "periodic"])
@pytest.mark.parametrize("dim", [1, 2, 3])
def test_fourier_modes_are_eigenvectors_with_the_stated_eigenvalue(boundary, dim):
    g = ModeGrid({"dim": dim, "cells": 12, "k": 2, "boundary": boundary})
    lap = GridLaplacian(g.shape, (g.h,) * dim, ((boundary, boundary),) * dim)
    phi = g.mode()
    residual = lap.apply(phi) - g.discrete_eigenvalue() * phi
    # each point's stencil rounds by a few eps of its terms (2d + 1 of size |phi| / h^2)
    assert np.max(np.abs(residual)) <= 8 * (2 * dim + 1) * np.finfo(float).eps / g.h ** 2


def test_sawtooth_has_the_largest_eigenvalue_on_an_even_periodic_grid():
    g = ModeGrid({"dim": 2, "cells": 8, "k": 1, "boundary": "periodic"})
    lap = GridLaplacian(g.shape, (g.h,) * 2, (("periodic",) * 2,) * 2)
    j = np.arange(8)
    saw = np.multiply.outer((-1.0) ** j, (-1.0) ** j)
    assert np.allclose(lap.apply(saw), -g.top_eigenvalue() * saw, rtol=1e-14, atol=0)
    assert g.top_eigenvalue() == pytest.approx(lap.spectral_radius_bound(), rel=1e-15)
    dense = lap.matrix().toarray()
    assert np.max(np.abs(np.linalg.eigvalsh(dense))) == pytest.approx(g.top_eigenvalue(),
                                                                      rel=1e-12)
