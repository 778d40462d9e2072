"""The cell list finds exactly the brute-force pairs within the radius (open and periodic, 2D and
3D, random points, batch axes), each once with i < j and sep = x_j - x_i (minimum image)."""
import numpy as np
import pytest

from refsim.models.cell_list import all_pairs, neighbour_pairs


def _sorted(i, j, sep):
    order = np.lexsort((j, i))
    return i[order], j[order], sep[order]


def _brute(x, radius, box):
    i, j, sep = all_pairs(x, box)
    close = np.einsum("ij,ij->i", sep, sep) < radius * radius
    return _sorted(i[close], j[close], sep[close])


CASES = [(2, None, 1.3), (3, None, 1.3), (2, (5.0, 6.5), 1.3), (3, (5.0, 6.0, 7.5), 1.3),
         # periodic axes of 1 and 2 cells: the full shell, offsets taken once modulo the axis
         (2, (2.6, 5.0), 1.3), (3, (2.6, 3.0, 9.0), 1.3)]


@pytest.mark.parametrize("dim, box, radius", CASES)
def test_cell_list_equals_brute_force(dim, box, radius):
    rng = np.random.default_rng(dim + (0 if box is None else 10))
    # periodic: points far outside the box, so the wrapping is exercised
    x = rng.uniform(-12.0, 12.0, (3, 80, dim)) if box else rng.uniform(0, 6, (3, 80, dim))
    got = _sorted(*neighbour_pairs(x, radius, box))
    want = _brute(x, radius, box)
    assert len(want[0]) > 50  # the draw has pairs to find
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
    assert np.all(got[0] < got[1])
    assert np.all(got[0] // 80 == got[1] // 80)  # never across batch instances
    # the same subtraction up to the wrap: |sep| <= 24 m, a few eps of it
    assert np.max(np.abs(got[2] - want[2])) <= 8 * np.finfo(float).eps * 24.0


def test_sparse_open_points_cap_the_grid():
    """Two far clusters: the cells are enlarged (at most 4 per particle), pairs still exact."""
    rng = np.random.default_rng(3)
    x = np.concatenate([rng.uniform(0, 1, (20, 3)), rng.uniform(1e4, 1e4 + 1, (20, 3))])
    got, want = _sorted(*neighbour_pairs(x, 0.3)), _brute(x, 0.3, None)
    assert len(want[0]) > 0 and np.array_equal(got[0], want[0]) and np.array_equal(got[1],
                                                                                 want[1])


def test_infinite_radius_is_every_pair():
    x = np.random.default_rng(4).normal(size=(7, 2))
    i, j, _ = neighbour_pairs(x, np.inf)
    assert len(i) == 21 and np.all(i < j)


def test_bad_radius_is_refused():
    with pytest.raises(ValueError, match="radius"):
        neighbour_pairs(np.zeros((2, 2)), 0.0)
    with pytest.raises(ValueError, match="periodic"):
        neighbour_pairs(np.zeros((2, 2)), np.inf, box=(3.0, 3.0))
