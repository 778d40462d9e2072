"""refsim.models.collision.sat (and box_distance) against closed forms: a unit square against
the same square turned 45 degrees (2D), a unit cube against one turned 45 degrees about z
(3D: MODELS.md's probe, distance (3 - sqrt 2)/2 = 0.792893 at centres 2 apart, penetration
(1 - sqrt 2)/2 = -0.207107 at 1), an edge-edge pair only the 9 cross-product axes separate, a
vertex-vertex pair where SAT's separation is only a lower bound, aligned boxes (every cross
product zero: skipped, no NaN), and padding."""
from __future__ import annotations

import numpy as np
import pytest
from ulp import assert_ulp

from refsim.models.collision.sat import box_pairs, box_sat, polygon_pairs, polygon_sat

SQ2 = np.sqrt(2.0)
# the closed forms and the SAT differ in their operations (sums of products of rounded cosines,
# square roots): a few roundings of the coordinates' size (<= 3 m here), 16 ulps of 3 m
ULPS, SCALE = 16, 3.0


def _turn2(deg):
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, -s], [s, c]])


def _turn3(axis, deg):
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    i, j = [k for k in range(3) if k != axis]
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


SQUARE = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])


def _square_pairs(offsets, deg=45.0):
    """A unit square at the origin, B the same turned `deg` with centre at each offset."""
    b = SQUARE @ _turn2(deg).T
    n = len(offsets)
    return (np.repeat(SQUARE[None], n, 0), np.full(n, 4),
            b[None] + np.asarray(offsets, float)[:, None], np.full(n, 4))


@pytest.mark.parametrize("direction", [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)])
def test_square_against_turned_square(direction):
    u = np.array(direction)
    x = np.array([2.0, 1.5, 1.0, 0.8])
    out = polygon_pairs(*_square_pairs(x[:, None] * u))
    want = x - 0.5 - SQ2 / 2  # the square's face at 0.5, the turned one's corner sqrt(2)/2 out
    assert_ulp(out["distance"], want, ULPS, "closed form vs SAT/vertex-edge", SCALE)
    np.testing.assert_array_equal(out["overlap"], (want <= 0).astype(float))
    assert_ulp(out["normal"], np.broadcast_to(u, (4, 2)), ULPS, "unit axis vs edge normal", 1.0)


def test_polygon_swapped_sides_flip_the_normal():
    a, ac, b, bc = _square_pairs([[1.0, 0.0], [2.0, 0.0]])
    there = polygon_pairs(a, ac, b, bc)
    back = polygon_pairs(b, bc, a, ac)
    assert_ulp(back["distance"], there["distance"], ULPS, "the same pair seen from B", SCALE)
    assert_ulp(back["normal"], -there["normal"], ULPS, "the same pair seen from B", 1.0)


def test_polygon_vertex_vertex_gap_is_only_bounded_by_sat():
    """Two unit squares corner to corner at (2, 2): distance sqrt 2; SAT's largest separation
    is 1 (a face axis): a lower bound, not the distance."""
    a, ac = SQUARE[None], np.array([4])
    b = SQUARE[None] + 2.0
    out = polygon_pairs(a, ac, b, ac)
    sep, _ = polygon_sat(a, ac, b, ac)
    assert_ulp(sep, [1.0], ULPS, "face separation", SCALE)
    assert_ulp(out["distance"], [SQ2], ULPS, "corner to corner", SCALE)
    assert_ulp(out["normal"], [[1 / SQ2, 1 / SQ2]], ULPS, "diagonal", 1.0)


def test_padding_is_ignored():
    """A triangle padded to 12 rows of junk answers as the bare triangle, bit for bit (the
    padded rows are replaced by vertex 0 before any arithmetic)."""
    tri = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    other = tri + [1.2, 0.3]
    bare = polygon_pairs(tri[None], [3], other[None], [3])
    junk = np.full((1, 12, 2), 1e6)
    pa, pb = junk.copy(), -junk.copy()
    pa[0, :3], pb[0, :3] = tri, other
    padded = polygon_pairs(pa, [3], pb, [3])
    for name in bare:
        np.testing.assert_array_equal(padded[name], bare[name])


def _cube_pair(b_center, b_rot, a_rot=np.eye(3)):
    n = len(b_center)
    half = np.full((n, 3), 0.5)
    return (np.zeros((n, 3)), half, np.repeat(a_rot[None], n, 0),
            np.asarray(b_center, float), half.copy(), np.repeat(b_rot[None], n, 0))


def test_cube_against_cube_turned_45_about_z():
    x = np.array([2.0, 1.5, 1.0])
    out = box_pairs(*_cube_pair(np.stack([x, 0 * x, 0 * x], 1), _turn3(2, 45.0)))
    want = x - 0.5 - SQ2 / 2
    assert_ulp(out["distance"], want, ULPS, "closed form vs SAT/features", SCALE)
    assert_ulp(out["distance"][[0, 2]], [(3 - SQ2) / 2, (1 - SQ2) / 2], ULPS,
               "MODELS.md's probe values", SCALE)
    np.testing.assert_array_equal(out["overlap"], [0.0, 0.0, 1.0])
    assert_ulp(out["normal"], np.tile([1.0, 0.0, 0.0], (3, 1)), ULPS, "the x axis", 1.0)


def test_edge_edge_needs_the_cross_axes():
    """A turned 45 degrees about z (an edge along z at x = sqrt(2)/2), B 45 degrees about y (an
    edge along y at x = c - sqrt(2)/2): the edges cross at right angles, apart by c - sqrt 2.
    Overlapping (c = 1.3) only the cross axis z x y = x gives the depth sqrt 2 - c; the face
    axes overlap by more (about 0.43)."""
    c = np.array([2.0, 1.5, 1.3])
    args = _cube_pair(np.stack([c, 0 * c, 0 * c], 1), _turn3(1, 45.0), _turn3(2, 45.0))
    out = box_pairs(*args)
    assert_ulp(out["distance"], c - SQ2, ULPS, "edge to edge", SCALE)
    np.testing.assert_array_equal(out["overlap"], [0.0, 0.0, 1.0])
    assert_ulp(np.abs(out["normal"]), np.tile([1.0, 0.0, 0.0], (3, 1)), ULPS, "x", 1.0)
    assert np.all(out["normal"][:, 0] > 0), "from A towards B"
    faces_only = box_sat(*args, parallel_sin=np.inf)[0]  # every cross axis skipped
    assert faces_only[2] < -0.4, "the face axes alone give a wrong depth (the planted defect)"


def test_vertex_vertex_boxes_and_sat_lower_bound():
    """Unit cubes corner to corner at (2, 2, 2): distance sqrt 3, SAT's separation 1."""
    args = _cube_pair(np.array([[2.0, 2.0, 2.0]]), np.eye(3))
    out = box_pairs(*args)
    assert_ulp(out["distance"], [np.sqrt(3.0)], ULPS, "corner to corner", SCALE)
    assert_ulp(out["normal"], [np.full(3, 1 / np.sqrt(3.0))], ULPS, "diagonal", 1.0)
    assert_ulp(box_sat(*args)[0], [1.0], ULPS, "a face axis", SCALE)


def test_aligned_boxes_skip_the_parallel_cross_axes():
    """Identity rotations: every cross product is zero (or a face normal): skipped, and the
    answers are the face ones, finite."""
    b = np.array([[1.7, 0.2, -0.1], [0.6, 0.3, 0.0], [0.2, 0.9, 0.1]])
    out = box_pairs(*_cube_pair(b, np.eye(3)))
    assert all(np.all(np.isfinite(v)) for v in out.values())
    assert_ulp(out["distance"], [0.7, -0.4, -0.1], ULPS, "face gaps", SCALE)
    np.testing.assert_array_equal(np.sign(out["normal"]), [[1, 0, 0], [1, 0, 0], [0, 1, 0]])


def test_box_swapped_sides_flip_the_normal():
    rng = np.random.default_rng(3)
    b = rng.uniform(-1.5, 1.5, (50, 3))
    args = _cube_pair(b, _turn3(0, 30.0) @ _turn3(2, 20.0), _turn3(1, 10.0))
    there = box_pairs(*args)
    back = box_pairs(*args[3:], *args[:3])
    assert_ulp(back["distance"], there["distance"], ULPS,
               "the same pair from the other side: other roundings of the same terms", SCALE)
    np.testing.assert_array_equal(back["overlap"], there["overlap"])
    # a normal from closest points (or a face axis) turns by the points' round-off over the
    # distance: ULPS x 3 m / min |d| (min |d| = 5.7e-3 here: 8.4e3 ulps; a sign flip is 2e16)
    assert_ulp(back["normal"], -there["normal"],
               ULPS * SCALE / np.abs(there["distance"]).min(), "round-off / distance", 1.0)


def test_touching_exactly_counts_as_overlap():
    """Squares and cubes face to face at exactly 0: overlap (closed shapes: SAT's separation
    <= 0), distance 0, the face's normal."""
    out = polygon_pairs(SQUARE[None], [4], SQUARE[None] + [1.0, 0.25], [4])
    assert out["overlap"][0] == 1.0 and out["distance"][0] == 0.0
    assert_ulp(out["normal"], [[1.0, 0.0]], ULPS, "face normal", 1.0)
    box = box_pairs(*_cube_pair(np.array([[1.0, 0.25, 0.5]]), np.eye(3)))
    assert box["overlap"][0] == 1.0 and box["distance"][0] == 0.0
    assert_ulp(box["normal"], [[1.0, 0.0, 0.0]], ULPS, "face normal", 1.0)
