"""A bounding volume hierarchy over spheres (issue 28; slide 001's BVH), numpy throughout: no
Python loop over primitives, nodes, queries or pairs, only over the tree's levels.

Layout: the primitives are put in one order and every node holds a contiguous range of it;
a node of more than `leaf_size` primitives is split in two at a position the split rule gives,
the others are leaves (the leaves partition the order). The tree is stored level by level
(root at level 0): each node's range, its first child's index in the next level (-1 for a
leaf), the box of its spheres (c -+ r, widened by the round-off pad below), the box of its
centres and its largest radius. The build goes down once for the ranges and up once for
the boxes (the leaves' by one np.minimum.reduceat over the ordered spheres, maxima negated;
an inner node's from its two children).

Splits (formulations):
- "morton" (default): one sort by the 63-bit Morton code of the centres (21 bits per axis over
  the centres' box), and each node split where its highest differing code bit flips (one
  searchsorted per level; at the middle where all its codes are equal): a spatial median of
  the node's Morton cell, the LBVH (radix) tree. Build O(N log N): the sort, then O(N) per
  level.
- "median": top-down, level by level, each node's range partitioned at its middle along the
  longest axis of its centres' box (np.argpartition over the level's ranges as rows of one
  padded matrix): an object median on the widest axis (a k-d split), a balanced tree. Build
  O(N) per level, O(N log N) in all.
An object median along the Morton order instead (an implicit complete tree) was tried first:
its nodes straddle the octant boundaries, their boxes span both sides, and the nearest
query's frontier held about 100 leaves per query at N = 1e5 (6 with either split above).

Queries, batched over M query spheres (centre c_q, radius r_q):
- `overlap_pairs`: every (query, primitive) pair with |c_q - c_p| <= r_q + r_p, sorted by query
  then primitive: a frontier of (query, node) pairs, level by level, keeps the pairs whose node
  box is within r_q of c_q; kept pairs at inner nodes go on to both children, kept pairs at
  leaves are expanded to their primitives, and there the exact sphere test decides
  (|c_q - c_p|^2 against (r_q + r_p)^2, as a brute force computes it).
- `nearest`: for each query centre the primitive whose surface is nearest, the least
  |c_q - c_p| - r_p (negative inside a sphere; ties to the lower index), and that distance:
  branch and bound on the same frontier. A per-query bound `best` from one greedy path down
  (the child of least lower bound at each level) and its leaf's primitives, then the frontier
  drops the nodes whose lower bound exceeds `best`. (Tightening `best` on the way down by
  each node's upper bound, the farthest corner of its centres' box less its least radius,
  pruned no further node of these batches: left out.) Lower bound of a node: the distance
  to its centres' box less its largest radius, and where c_q is outside the node's sphere
  box, the distance to that box (no sphere of the node then contains c_q, and each sphere
  lies in the box).
Round-off: the boxes are widened, and the pruning tests loosened, by PAD_EPS eps times the
scene's scale (largest |coordinate| of any centre plus the largest radius), which exceeds the
rounding of c -+ r, of the box distances and of the exact test's own terms: no pair the exact
test at the leaves accepts, and no nearest candidate, is pruned on the way down.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

EPS = float(np.finfo(float).eps)
PAD_EPS = 8.0  # the round-off pad in eps of the scale: 4 for each of two rounded terms
SPLITS = ("morton", "median")
MORTON_BITS = 21  # per axis: 63 bits in a uint64
BOX_KEYS = ("box_lo", "box_hi", "c_lo", "c_hi", "r_max")
COLUMNS = {"box_lo": slice(0, 3), "box_hi": slice(3, 6), "c_lo": slice(6, 9),
           "c_hi": slice(9, 12), "r_max": 12}  # of a node's packed row
SIGN = np.array([1.0] * 3 + [-1.0] * 3 + [1.0] * 3 + [-1.0] * 3 + [-1.0])  # maxima: -1


@dataclass(frozen=True, eq=False)
class Bvh:
    """A BVH (see the module docstring); `levels[d]` holds level d's node arrays: "start",
    "end" (the range in the order), "child" (first child's index in level d + 1, -1 for a
    leaf), BOX_KEYS, and "packed": the BOX_KEYS columns side by side (13 per node), the one
    gather a query does per level."""

    order: np.ndarray  # (N,) primitive index at each position of the tree's order
    center: np.ndarray  # (N, 3) the centres in that order
    radius: np.ndarray  # (N,)
    levels: tuple
    leaf_size: int
    split: str
    pad: float  # the absolute round-off pad (m)

    @property
    def depth(self) -> int:
        return len(self.levels) - 1

    @property
    def size(self) -> int:
        return len(self.order)


def _spread_bits(v: np.ndarray) -> np.ndarray:
    """21-bit integers -> 63 bits with two zeros after each bit (the Morton interleave)."""
    x = v.astype(np.uint64) & np.uint64(0x1FFFFF)
    for shift, mask in ((32, 0x1F00000000FFFF), (16, 0x1F0000FF0000FF), (8, 0x100F00F00F00F00F),
                        (4, 0x10C30C30C30C30C3), (2, 0x1249249249249249)):
        x = (x | (x << np.uint64(shift))) & np.uint64(mask)
    return x


def morton_codes(center: np.ndarray) -> np.ndarray:
    """(N,) uint64 Morton codes of the centres quantised to 2^21 cells per axis of their box."""
    rows = np.ascontiguousarray(np.asarray(center, dtype=float).T)  # (3, N): fast reductions
    lo, hi = rows.min(axis=1)[:, None], rows.max(axis=1)[:, None]
    span = np.where(hi > lo, hi - lo, 1.0)
    cells = np.floor((rows - lo) / span * ((1 << MORTON_BITS) - 1)).astype(np.int64)
    x, y, z = (_spread_bits(cells[k]) for k in range(3))
    return (x << np.uint64(2)) | (y << np.uint64(1)) | z


def _radix_split(codes, start, end) -> np.ndarray:
    """Where each range's highest differing Morton bit flips (its middle if all codes equal)."""
    a, b = codes[start], codes[end - 1]
    x = a ^ b
    for shift in (1, 2, 4, 8, 16, 32):  # every bit below the highest set one
        x = x | (x >> np.uint64(shift))
    first_high = (a & ~x) | ((x >> np.uint64(1)) + np.uint64(1))  # least code past the flip
    cut = np.searchsorted(codes, first_high, side="left")
    return np.where(a == b, (start + end) // 2, cut)


def _median_split(rows, order, start, end):
    """Each range of `order` partitioned along its centres' widest axis (`rows`: the centres
    transposed, (3, N)), its first count // 2 positions the lower half (in place of `order`):
    the ranges as rows of one padded matrix (pads +inf), np.argpartition along the rows at
    each half and at each row's end (the pads past it). O(N) per level: a median split's
    ranges at one level differ in length by one at most."""
    count = end - start
    span = int(count.max())
    idx = start[:, None] + np.arange(span)[None, :]
    valid = idx < end[:, None]
    idx = np.where(valid, idx, start[:, None])
    members = order[idx]
    c = np.take(rows, members, axis=1)  # (3, ranges, span): reductions along contiguous rows
    lo = np.where(valid, c, np.inf).min(axis=2)
    hi = np.where(valid, c, -np.inf).max(axis=2)
    axis = np.argmax(hi - lo, axis=0)
    key = np.where(valid, np.take_along_axis(c, axis[None, :, None], 0)[0], np.inf)
    kth = np.union1d(count // 2, count[count < span])  # pads sorted past every row's end
    parted = np.take_along_axis(members, np.argpartition(key, kth, axis=1), axis=1)
    order[idx[valid]] = parted[valid]


def _ranges(center, codes, leaf_size, split):
    """The order and every level's (start, end, child) arrays, root first."""
    n = len(center)
    order = np.argsort(codes) if split == "morton" else np.arange(n)
    sorted_codes = codes[order] if split == "morton" else None
    rows = None if split == "morton" else np.ascontiguousarray(center.T)
    start, end = np.zeros(1, dtype=np.int64), np.full(1, n, dtype=np.int64)
    levels = []
    while len(start):
        inner = end - start > leaf_size
        child = np.where(inner, 2 * (np.cumsum(inner) - 1), -1)
        levels.append({"start": start, "end": end, "child": child})
        s, e = start[inner], end[inner]
        if split == "morton":
            cut = _radix_split(sorted_codes, s, e)
        else:
            if len(s):
                _median_split(rows, order, s, e)
            cut = (s + e) // 2
        start = np.stack([s, cut], axis=1).ravel()
        end = np.stack([cut, e], axis=1).ravel()
    return order, levels


def build(center, radius, leaf_size: int = 8, split: str = "morton") -> Bvh:
    """The BVH of N spheres (centres (N, 3), radii (N,) >= 0)."""
    center = np.ascontiguousarray(center, dtype=float)
    radius = np.ascontiguousarray(radius, dtype=float)
    n = len(center)
    if n == 0 or center.shape != (n, 3) or radius.shape != (n,):
        raise ValueError(f"bvh.build needs (N, 3) centres and (N,) radii, N >= 1; got "
                         f"{center.shape} and {radius.shape}")
    if split not in SPLITS:
        raise ValueError(f"bvh split must be one of {SPLITS}, got {split!r}")
    if leaf_size < 2:
        raise ValueError(f"bvh leaf_size must be >= 2, got {leaf_size}")
    codes = morton_codes(center) if split == "morton" else None
    order, levels = _ranges(center, codes, leaf_size, split)
    c, r = np.take(center, order, axis=0), radius[order]
    pad = PAD_EPS * EPS * (float(np.abs(center).max()) + float(radius.max()))
    # the leaves, every level's together, partition the order: one reduceat for them all
    leaf_start = np.concatenate([lv["start"][lv["child"] < 0] for lv in levels])
    by_start = np.argsort(leaf_start)
    back = np.empty_like(by_start)
    back[by_start] = np.arange(len(by_start))  # start order -> level order
    at = leaf_start[by_start]
    # one row per node, BOX_KEYS' columns side by side, the maxima negated so that one
    # minimum reduces them all (negation is exact: the same values as a min and a max)
    ct, rt = np.ascontiguousarray(c.T), r[None, :]  # rows of N: reduceat along contiguous rows
    signed = np.concatenate([ct - rt, -(ct + rt), ct, -ct, -rt])
    leaf_rows = np.minimum.reduceat(signed, at, axis=1).T[back]
    leaf_rows[:, :6] -= pad  # box_lo - pad, -(box_hi + pad)
    first_leaf = np.cumsum([0] + [int((lv["child"] < 0).sum()) for lv in levels])
    for d in range(len(levels) - 1, -1, -1):  # leaves, then inner nodes from their children
        lv = levels[d]
        inner = lv["child"] >= 0
        rows = np.empty((len(lv["start"]), len(SIGN)))
        rows[~inner] = leaf_rows[first_leaf[d]:first_leaf[d + 1]]
        if inner.any():
            below, first = levels[d + 1]["signed"], lv["child"][inner]
            rows[inner] = np.minimum(np.take(below, first, axis=0),
                                     np.take(below, first + 1, axis=0))
        lv["signed"] = rows
    for lv in levels:
        lv["packed"] = lv.pop("signed") * SIGN
        lv.update({key: lv["packed"][:, cols] for key, cols in COLUMNS.items()})
    return Bvh(order=order, center=c, radius=r, levels=tuple(levels),
               leaf_size=int(leaf_size), split=split, pad=pad)


def _rows(array, index):
    """array[index] along the first axis (np.take: 2-3x faster than fancy indexing on rows)."""
    return np.take(array, index, axis=0)


def _box_distance(point, lo, hi) -> np.ndarray:
    """(k,) distance of each point to its box (0 inside)."""
    gap = np.maximum(np.maximum(lo - point, point - hi), 0.0)
    return np.sqrt(np.einsum("kj,kj->k", gap, gap))


def _expand(tree: Bvh, query, start, end):
    """(query, leaf range) pairs expanded to (query, tree position) pairs."""
    span = tree.leaf_size
    pos = start[:, None] + np.arange(span)[None, :]
    keep = pos < end[:, None]
    return np.broadcast_to(query[:, None], pos.shape)[keep], pos[keep]


def _frontier(tree: Bvh, query, keep_pair):
    """Down the levels from (query, root): `keep_pair(d, query, node)` -> mask of the pairs
    kept; kept inner nodes go on to both children. Returns the kept (query, position) pairs
    of the leaves' primitives."""
    node = np.zeros(len(query), dtype=np.int64)
    found_q, found_s, found_e = [], [], []
    for d, lv in enumerate(tree.levels):
        keep = keep_pair(d, query, node)
        query, node = query[keep], node[keep]
        child = lv["child"][node]
        leaf = child < 0
        found_q.append(query[leaf])
        found_s.append(lv["start"][node[leaf]])
        found_e.append(lv["end"][node[leaf]])
        query = np.repeat(query[~leaf], 2)
        node = (child[~leaf][:, None] + np.array([0, 1])).ravel()
    return _expand(tree, np.concatenate(found_q), np.concatenate(found_s),
                   np.concatenate(found_e))


def overlap_pairs(tree: Bvh, query_center, query_radius) -> np.ndarray:
    """(k, 2) int64 (query, primitive) pairs with |c_q - c_p| <= r_q + r_p, sorted."""
    qc = np.asarray(query_center, dtype=float)
    qr = np.asarray(query_radius, dtype=float)

    def near(d, query, node):
        row, point = _rows(tree.levels[d]["packed"], node), _rows(qc, query)
        gap = np.maximum(np.maximum(row[:, 0:3] - point, point - row[:, 3:6]), 0.0)
        reach = qr[query] + tree.pad
        return np.einsum("kj,kj->k", gap, gap) <= reach * reach

    query, pos = _frontier(tree, np.arange(len(qc)), near)
    diff = _rows(qc, query) - _rows(tree.center, pos)
    reach = qr[query] + tree.radius[pos]
    hit = np.einsum("kj,kj->k", diff, diff) <= reach * reach
    pairs = np.stack([query[hit], tree.order[pos[hit]]], axis=1)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


def _lower_bound(tree: Bvh, d: int, point, node):
    """A lower bound of min |c_q - c_p| - r_p over each node's primitives."""
    row = _rows(tree.levels[d]["packed"], node)
    to_centres = _box_distance(point, row[:, 6:9], row[:, 9:12]) - row[:, 12]
    to_box = _box_distance(point, row[:, 0:3], row[:, 3:6])
    return np.where(to_box > 0, np.maximum(to_box, to_centres), to_centres)


def _values(tree: Bvh, qc, query, pos):
    diff = _rows(qc, query) - _rows(tree.center, pos)
    return np.sqrt(np.einsum("kj,kj->k", diff, diff)) - tree.radius[pos]


def _descend(tree: Bvh, qc) -> np.ndarray:
    """A first bound per query: down one path, to the child of least lower bound at each
    level, and the least value over that leaf's primitives."""
    m = len(qc)
    query, node = np.arange(m), np.zeros(m, dtype=np.int64)
    leaf_q, leaf_n, leaf_d = [], [], []
    for d, lv in enumerate(tree.levels):
        child = lv["child"][node]
        leaf = child < 0
        leaf_q.append(query[leaf])
        leaf_n.append(node[leaf])
        leaf_d.append(np.full(int(leaf.sum()), d))
        query, first = query[~leaf], child[~leaf]
        if not len(query):
            break
        lower = _lower_bound(tree, d + 1, np.repeat(_rows(qc, query), 2, axis=0),
                             (first[:, None] + np.array([0, 1])).ravel())
        node = first + np.argmin(lower.reshape(-1, 2), axis=1)
    query, node, depth = map(np.concatenate, (leaf_q, leaf_n, leaf_d))
    start = np.concatenate([tree.levels[d]["start"][node[depth == d]]
                            for d in range(len(tree.levels))])
    end = np.concatenate([tree.levels[d]["end"][node[depth == d]]
                          for d in range(len(tree.levels))])
    query = np.concatenate([query[depth == d] for d in range(len(tree.levels))])
    query, pos = _expand(tree, query, start, end)
    best = np.full(m, np.inf)
    np.minimum.at(best, query, _values(tree, qc, query, pos))
    return best


def nearest(tree: Bvh, query_center):
    """(index (M,) int64, distance (M,)): the primitive whose surface is nearest each centre,
    the least |c_q - c_p| - r_p (ties to the lower index), and that value."""
    qc = np.asarray(query_center, dtype=float)
    m = len(qc)
    slack = 2.0 * tree.pad  # the bounds' round-off, with the pad's own
    best = _descend(tree, qc) + slack

    def promising(d, query, node):
        return _lower_bound(tree, d, _rows(qc, query), node) <= best[query]

    query, pos = _frontier(tree, np.arange(m), promising)
    value = _values(tree, qc, query, pos)
    least = np.full(m, np.inf)
    np.minimum.at(least, query, value)
    prim = tree.order[pos]
    index = np.full(m, np.iinfo(np.int64).max)
    at_least = value == least[query]
    np.minimum.at(index, query[at_least], prim[at_least])
    return index, least
