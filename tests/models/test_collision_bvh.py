"""The BVH over spheres (refsim.models.collision.bvh): its tree holds what it claims (boxes
containing their spheres and children, leaves partitioning the primitives), and both queries
equal brute force exactly, on both splits, on random, clustered, degenerate (coincident
centres) and touching (grid) sets. The brute force here does the tree's own leaf arithmetic
(the same einsum over the same (k, 3) rows), so the answers compare bit for bit."""
import numpy as np
import pytest

from refsim.models.collision import bvh


def brute(center, radius, qc, qr):
    """Every (query, primitive) pair, flattened to rows as the tree's leaves compute them."""
    m, n = len(qc), len(center)
    q, p = np.repeat(np.arange(m), n), np.tile(np.arange(n), m)
    diff = qc[q] - center[p]
    d2 = np.einsum("kj,kj->k", diff, diff)
    reach = qr[q] + radius[p]
    pairs = np.stack([q, p], axis=1)[d2 <= reach * reach]
    value = (np.sqrt(d2) - radius[p]).reshape(m, n)
    index = np.argmin(value, axis=1)  # the first of equal least values: the lower index
    return pairs, index, value[np.arange(m), index]


def _random(rng, n, m, spread=10.0):
    side = (n * spread) ** (1 / 3)
    return (rng.uniform(-side, side, (n, 3)), np.exp(rng.uniform(np.log(0.1), 0.0, n)),
            rng.uniform(-side, side, (m, 3)), np.exp(rng.uniform(np.log(0.1), 0.0, m)))


def _sets():
    rng = np.random.default_rng(7)
    yield "random_1", _random(rng, 1, 50, spread=1.0)
    yield "random_9", _random(rng, 9, 50)
    yield "random_2000", _random(rng, 2000, 300)
    line = np.zeros((500, 3))
    line[:, 0] = rng.uniform(0, 50, 500)  # every centre on one axis: flat boxes
    yield "line", (line, np.full(500, 0.3), rng.uniform(-1, 50, (200, 3)) * [1, 0.02, 0.02],
                   rng.uniform(0.1, 1.0, 200))
    same = np.tile([1.5, -2.0, 0.25], (40, 1))  # one Morton code, zero-width boxes
    yield "coincident", (same, rng.uniform(0.5, 1.0, 40), rng.uniform(-2, 3, (60, 3)),
                         rng.uniform(0.1, 1.0, 60))
    grid = np.stack(np.meshgrid(*[np.arange(8) * 0.1] * 3, indexing="ij"), -1).reshape(-1, 3)
    # spheres of radius 0.05 on a 0.1 grid touch their neighbours to round-off
    yield "touching", (grid, np.full(len(grid), 0.05), grid[::7] + 1e-17,
                       np.full(len(grid[::7]), 0.05))
    # queries touching a primitive along x to a few ulps: the exact test accepts some that an
    # unpadded box (c + r rounded) would prune
    center, radius = rng.uniform(-10, 10, (400, 3)), rng.uniform(0.01, 1.0, 400)
    qr = rng.uniform(0.01, 1.0, 400)
    qc = center.copy()
    qc[:, 0] = center[:, 0] + radius + qr
    qc[:, 0] += rng.integers(-4, 5, 400) * np.spacing(qc[:, 0])
    yield "ulp_touching", (center, radius, qc, qr)
    cluster = np.concatenate([rng.normal(0, 0.01, (300, 3)), rng.normal(100, 5, (300, 3))])
    yield "clusters", (cluster, rng.uniform(0.001, 0.02, 600), rng.normal(0, 0.02, (100, 3)),
                       rng.uniform(0.001, 0.02, 100))


SETS = dict(_sets())


@pytest.mark.parametrize("split", bvh.SPLITS)
@pytest.mark.parametrize("name", sorted(SETS))
def test_queries_equal_brute_force(name, split):
    center, radius, qc, qr = SETS[name]
    tree = bvh.build(center, radius, leaf_size=4, split=split)
    want_pairs, want_index, want_distance = brute(center, radius, qc, qr)
    pairs = bvh.overlap_pairs(tree, qc, qr)
    index, distance = bvh.nearest(tree, qc)
    assert len(want_pairs) > 0
    np.testing.assert_array_equal(pairs, want_pairs)
    np.testing.assert_array_equal(index, want_index)
    np.testing.assert_array_equal(distance, want_distance)  # same operations, same order


def test_nearest_inside_a_sphere_is_negative_and_found():
    """Query centres inside big spheres: the least |c_q - c_p| - r_p is negative; a bound of
    0 for a node whose box holds c_q would drop it."""
    rng = np.random.default_rng(3)
    center = rng.uniform(-20, 20, (3000, 3))
    radius = np.exp(rng.uniform(np.log(0.05), np.log(5.0), 3000))
    qc = center[rng.choice(3000, 200)] + rng.normal(0, 0.5, (200, 3))
    for split in bvh.SPLITS:
        tree = bvh.build(center, radius, leaf_size=8, split=split)
        index, distance = bvh.nearest(tree, qc)
        _, want_index, want_distance = brute(center, radius, qc, np.ones(200))
        assert (want_distance < 0).sum() > 50
        np.testing.assert_array_equal(index, want_index)
        np.testing.assert_array_equal(distance, want_distance)


@pytest.mark.parametrize("split", bvh.SPLITS)
def test_tree_boxes_hold_their_spheres_and_children(split):
    center, radius, _, _ = SETS["random_2000"]
    tree = bvh.build(center, radius, leaf_size=5, split=split)
    assert sorted(tree.order) == list(range(len(center)))
    np.testing.assert_array_equal(tree.center, center[tree.order])
    covered = np.zeros(len(center), int)
    for d, lv in enumerate(tree.levels):
        count = lv["end"] - lv["start"]
        assert np.all(count >= 1)
        leaf = lv["child"] < 0
        assert np.all(count[leaf] <= 5) and np.all(count[~leaf] > 5)
        node = np.repeat(np.arange(len(count)), count)
        pos = np.concatenate([np.arange(s, e) for s, e in zip(lv["start"], lv["end"])])
        c, r = tree.center[pos], tree.radius[pos]
        # containment: comparisons of the stored values, no arithmetic beyond c -+ r
        assert np.all(lv["box_lo"][node] <= c - r[:, None])
        assert np.all(lv["box_hi"][node] >= c + r[:, None])
        assert np.all(lv["c_lo"][node] <= c) and np.all(lv["c_hi"][node] >= c)
        assert np.all(lv["r_max"][node] >= r)
        for s, e in zip(lv["start"][leaf], lv["end"][leaf]):
            covered[s:e] += 1
        if (~leaf).any():
            below = tree.levels[d + 1]
            first = lv["child"][~leaf]
            np.testing.assert_array_equal(below["start"][first], lv["start"][~leaf])
            np.testing.assert_array_equal(below["end"][first + 1], lv["end"][~leaf])
            np.testing.assert_array_equal(below["end"][first], below["start"][first + 1])
    np.testing.assert_array_equal(covered, 1)  # the leaves partition the order


@pytest.mark.parametrize("name", ["random_2000", "line", "clusters", "coincident"])
def test_median_split_halves_each_node_along_its_widest_axis(name):
    """Every inner node of the median tree: left child (count // 2 primitives) at or below
    the right along the longest side of the node's centres' box (a partition, not a sort)."""
    center, radius, _, _ = SETS[name]
    tree = bvh.build(center, radius, leaf_size=4, split="median")
    for lv in tree.levels:
        for s, e, child, lo, hi in zip(lv["start"], lv["end"], lv["child"], lv["c_lo"],
                                       lv["c_hi"]):
            if child < 0:
                continue
            axis, cut = int(np.argmax(hi - lo)), (s + e) // 2
            assert tree.center[s:cut, axis].max() <= tree.center[cut:e, axis].min()


def test_morton_codes_interleave_the_bits():
    """x, y, z cells 2^21 - 1, 0, 0 and the corner: code bits 2, 5, 8 ... of x."""
    center = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [0.0, 1.0, 0.0]])
    codes = bvh.morton_codes(center)
    x_bits = sum(1 << (3 * k + 2) for k in range(21))
    assert [int(c) for c in codes] == [x_bits, 0, 2 ** 63 - 1, x_bits >> 1]


def test_build_rejects_bad_input():
    with pytest.raises(ValueError, match="split"):
        bvh.build(np.zeros((3, 3)), np.ones(3), split="sah")
    with pytest.raises(ValueError, match="N >= 1"):
        bvh.build(np.zeros((0, 3)), np.ones(0))
    with pytest.raises(ValueError, match="leaf_size"):
        bvh.build(np.zeros((3, 3)), np.ones(3), leaf_size=1)
