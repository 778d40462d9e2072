"""Lennard-Jones model: forces are minus the gradient of the energy (central differences), the
shifted potential is continuous at the cut-off, the pair forces sum to zero (momentum), the
dense all-pairs path equals the pair-list path, and the part validates its fields."""
import math

import numpy as np
import pytest

from refsim.models.lennard_jones import (
    LennardJonesModel,
    LennardJonesSystem,
    pair_potential,
)
from refsim.scene.lennard_jones import LennardJones

EPS = np.finfo(float).eps


def _cloud(n, dim, side, seed):
    """n points in a box of `side`, none closer than 0.9 sigma (a jittered lattice)."""
    per_axis = math.ceil(n ** (1.0 / dim))
    grid = np.stack(np.meshgrid(*[np.arange(per_axis)] * dim, indexing="ij"), -1)
    sites = grid.reshape(-1, dim)[:n] * (side / per_axis)
    return sites + np.random.default_rng(seed).uniform(-0.05, 0.05, sites.shape)


@pytest.mark.parametrize("dim, box, shift", [(2, None, False), (3, None, True),
                                             (2, (7.0, 7.5), True), (3, (6.0, 6.0, 6.5), False)])
def test_forces_are_minus_energy_gradient(dim, box, shift):
    n = 25
    x = _cloud(n, dim, 6.0, dim)
    model = LennardJonesModel(1.3, 1.0, 2.5, shift, box)
    forces = model.forces(x)
    h = 1e-6  # central difference: truncation h^2 |U'''| ~ 1e-12 x 1e4, rounding eps |U| / h
    steps = np.eye(n * dim).reshape(-1, n, dim) * h
    # no pair may cross the cut-off within h (the energy jumps there): the draw is checked
    r = np.linalg.norm(model.pairs(x)[2], axis=1)
    assert np.all(np.abs(r - 2.5) > 10 * h)
    grad = (model.energy(x + steps) - model.energy(x - steps)) / (2 * h)
    # truncation h^2 |U'''| / 6 per pair (|U'''| <= 2e4 eps/sigma^3 at r >= 0.85 sigma, at most
    # n pairs touch a particle) plus the rounding of the energy sum: n eps (|U| + n) / h
    truncation = h * h * 2e4 / 6 * n
    rounding = n * EPS * (abs(float(model.energy(x))) + n) / h
    assert np.max(np.abs(forces.reshape(-1) + grad)) <= truncation + rounding
    scale = np.max(np.abs(forces))
    assert np.max(np.abs(forces.sum(axis=0))) <= 100 * n * EPS * scale  # Newton's third law


def test_shifted_potential_is_continuous_at_cutoff():
    rc = 2.5
    inside, outside = np.nextafter(rc, 0.0), rc
    assert abs(pair_potential(inside, 1.0, 1.0, rc, True)) <= 4 * EPS
    assert pair_potential(outside, 1.0, 1.0, rc, True) == 0.0
    jump = pair_potential(inside, 1.0, 1.0, rc, False)
    assert jump == pytest.approx(4 * (rc ** -12 - rc ** -6), rel=1e-12)  # unshifted jumps


def test_minimum_at_two_to_the_sixth():
    r0 = 2.0 ** (1.0 / 6.0)
    assert pair_potential(r0) == pytest.approx(-1.0, rel=1e-15)
    model = LennardJonesModel()
    assert np.max(np.abs(model.forces(np.array([[0.0, 0.0], [r0, 0.0]])))) <= 100 * EPS


def test_dense_path_equals_pair_list_and_batches():
    x = _cloud(12, 3, 4.0, 7)[None].repeat(2, axis=0)
    x[1] += 0.01
    dense = LennardJonesModel()  # cutoff inf: the dense (..., n, n, 3) path
    listed = LennardJonesModel(cutoff=1e6)  # a cell list holding every pair
    assert dense.dense and not listed.dense
    scale = np.max(np.abs(dense.forces(x)))
    assert np.max(np.abs(dense.forces(x) - listed.forces(x))) <= 100 * EPS * scale
    assert dense.energy(x).shape == (2,)
    assert np.allclose(dense.energy(x)[1], dense.energy(x[1]), rtol=1e-14, atol=0)


def test_system_moves_a_2d_scene_in_its_plane():
    x = np.zeros((2, 3))
    x[1, :2] = (1.0, 0.4)
    system = LennardJonesSystem(np.array([1.0, 2.0]), LennardJonesModel(), dim=2)
    a = system.accel(0.0, x.reshape(-1), np.zeros(6)).reshape(2, 3)
    # exact zeros: z = 0 separations, every z term is a product with an exact 0
    assert np.all(a[:, 2] == 0.0)
    assert np.allclose(1.0 * a[0] + 2.0 * a[1], 0.0, atol=1e-12 * np.abs(a).max())


@pytest.mark.parametrize("fields, match", [
    ({"epsilon": 0.0}, "epsilon"), ({"sigma": -1.0}, "sigma"), ({"cutoff": 0.0}, "cutoff"),
    ({"cutoff": 2.0, "box": (3.0, 5.0)}, "box"), ({"box": (10.0, 10.0)}, "box"),
    ({"cutoff": 2.0, "box": (5.0,)}, "box"), ({"shift": True}, "shift"),
    ({"cutoff": 2.0, "shift": 1}, "shift")])
def test_part_refuses_bad_fields(fields, match):
    with pytest.raises(ValueError, match=f"lennard_jones.{match}"):
        LennardJones(**fields)


@pytest.mark.parametrize("dim, box", [(2, None), (3, None), (2, (7.0, 7.5)),
                                      (3, (6.0, 6.0, 6.5)), (2, (4.9, 7.5))])
def test_forces_are_the_pair_list_sum_bit_for_bit(dim, box):
    """forces() sums in the cell list's sorted numbering; it must round exactly as the sum
    over neighbour_pairs (i < j, force g sep on j and -g sep on i, in pair order). The box
    (4.9, 7.5) has a periodic axis of one cell: the full-shell passes.
    Bit for bit by construction: the pair list below is written with forces()'s own operations
    in its order (cell_list.squared_norm's elementwise (x^2 + z^2) + y^2, never fused; g; one
    product per component; np.bincount's sequential sums), so only the summation order under
    test can differ. (An einsum |sep|^2 here would fuse its multiply-adds on aarch64.)"""
    x = _cloud(60, dim, 6.0, 11)[None].repeat(2, axis=0)
    x[1] += 0.013
    model = LennardJonesModel(1.1, 1.0, 2.45, True, box)
    i, j, sep = model.pairs(x)
    r2 = sep[:, 0] * sep[:, 0] + sep[:, -1] * sep[:, -1]  # x + y in 2D, x + z in 3D, then y
    if dim == 3:
        r2 = r2 + sep[:, 1] * sep[:, 1]
    s2 = 1.0 / r2  # sigma = 1
    s6 = s2 * s2 * s2
    g = 24.0 * 1.1 * (2.0 * s6 * s6 - s6) / r2
    rows = 2 * 60
    want = np.stack([np.bincount(j, g * sep[:, k], minlength=rows)
                     - np.bincount(i, g * sep[:, k], minlength=rows) for k in range(dim)], -1)
    assert len(i) > 100
    np.testing.assert_array_equal(model.forces(x), want.reshape(x.shape))
