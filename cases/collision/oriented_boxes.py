"""Random oriented box pairs (3D) against the Minkowski-difference oracle (issue 28, case 1;
slide 001's separating axes: the 15 axes of two boxes).

The batch (seeded): n pairs of boxes with half extents log-uniform in [0.05, 1] m per axis
(aspect ratios up to 20) and uniformly random rotations, A's centre uniform in [-L, L]^3, B's at
0-1.2 times the sum of the two half diagonals in a random direction: about half overlapping;
then a share of 20 % moved to touch at a signed gap log-uniform in +-[1e-10, 1e-3] m, a third
each vertex to vertex, vertex to face and edge to edge (`_touch`). Exact answers from the hull
of the 64 points {b_j - a_i} (cases/collision/_minkowski.py, Qhull), checked on closed forms
(tests/cases/test_oriented_boxes.py).

Measures, margin (1e-9 m) and bounds as convex_polygons states them (ConvexPairCase): B_i = K
eps S (1 + lever), K = 16, S the pair's largest |coordinate|, lever the pair's bounding-box
diagonal over the shortest box edge (2 h); plus the engine's declared settings
"distance_tolerance" (m) and "depth_relative_tolerance" (of each depth). Max B_i on the default
batch 1.5e-12 m. Measured on refsim: distance_err 1.6e-15 m, normal_err_deg 2.8e-5 (a pair ~1e-9
m apart; bound 0.036), normal_err_far_deg 9.8e-12 (bound 2.0e-8), no false negatives or
positives. The large variant (10^5 pairs) compares a seeded sample of `checked` = 5000 with
the oracle.

Planted once (the default batch): inputs rounded to float32: distance_err 8.8e-7 m, 26 false
negatives, 13 false positives, a normal 90 deg off (far pairs: 8.1e-3 deg); the normal's sign
flipped: 180 deg, the rest unchanged; the 9 edge-edge axes dropped (parallel_sin = inf):
distance_err 0.32 m, 44 false positives, 161 deg; A's half extents 0.1 % long: distance_err
1.1e-3 m, 62 false positives. SAT's largest separation as the distance of separated pairs: up
to 0.15 m (21 %) short, on 36 % of them (vertex-edge, edge-edge and vertex-vertex pairs).
"""
from __future__ import annotations

import numpy as np

from refsim.scene.queries import BoxPairs

from ._minkowski import ConvexPairCase

TOUCH_SHARE = 0.2  # pairs moved to a signed distance log-uniform in [TOUCH_LOW, TOUCH_HIGH] m
TOUCH_LOW, TOUCH_HIGH = 1e-10, 1e-3
CORNERS = np.array([[sx, sy, sz] for sx in (-1.0, 1.0) for sy in (-1.0, 1.0)
                    for sz in (-1.0, 1.0)])


def _rotations(rng, n):
    """n uniformly random rotations (unit quaternions from 4 normal deviates)."""
    q = rng.normal(size=(n, 4))
    w, x, y, z = (q / np.linalg.norm(q, axis=1)[:, None]).T
    rows = [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]
    return np.stack([np.stack(row, -1) for row in rows], axis=1)


def corners(center, half, rot):
    """(n, 8, 3) the boxes' vertices in world coordinates."""
    return center[:, None, :] + np.einsum("nij,nvj->nvi", rot, CORNERS[None] * half[:, None, :])


def _support(center, half, rot, u, free=None, lam=None):
    """The point of each box furthest along u: its vertex, or (free = a box axis index per
    row, lam in (-1, 1)) the point lam h of the way along the edge parallel to that axis."""
    local = np.sign(np.einsum("nji,nj->ni", rot, u)) * half
    if free is not None:
        rows = np.arange(len(u))
        local[rows, free] = (lam * half[rows, free])
    return center + np.einsum("nij,nj->ni", rot, local)


def _touch(rng, ca, ha, ra, cb, hb, rb) -> None:
    """Move a share TOUCH_SHARE of the B boxes (in place) to touch A at a signed gap g
    log-uniform in +-[TOUCH_LOW, TOUCH_HIGH] m along a unit u: B's support point along -u at g u
    from A's support point along u, a third each vertex to vertex (u random), vertex to face
    (u one of A's face normals, A's point inside the face, within 0.9 of its half sides) and
    edge to edge (u = a_i x b_j for an edge axis of each box, both points inside the edges).
    The plane normal to u through A's point separates them when g > 0: the distance is g;
    g < 0: the depth is at most |g|. The exact answers are the oracle's all the same."""
    n = len(ca)
    t = np.nonzero(rng.random(n) < TOUCH_SHARE)[0]
    m = len(t)
    gap = np.exp(rng.uniform(np.log(TOUCH_LOW), np.log(TOUCH_HIGH), m))
    gap *= np.where(rng.random(m) < 0.5, -1.0, 1.0)
    mode = rng.integers(0, 3, m)  # 0 vertex-vertex, 1 vertex-face, 2 edge-edge
    i, j = rng.integers(0, 3, m), rng.integers(0, 3, m)
    u = rng.normal(size=(m, 3))
    rows = np.arange(m)
    side = np.where(rng.random(m) < 0.5, -1.0, 1.0)
    cross = np.cross(ra[t][rows, :, i], rb[t][rows, :, j])
    u = np.where((mode == 1)[:, None], side[:, None] * ra[t][rows, :, i],
                 np.where((mode == 2)[:, None], cross, u))
    u /= np.linalg.norm(u, axis=1)[:, None]
    lam_a, lam_b = rng.uniform(-0.9, 0.9, m), rng.uniform(-0.9, 0.9, m)
    pa = _support(ca[t], ha[t], ra[t], u)
    local = rng.uniform(-0.9, 0.9, (m, 3)) * ha[t]  # A's face point: inside face i on `side`
    local[rows, i] = side * ha[t][rows, i]
    face = mode == 1
    pa[face] = (ca[t] + np.einsum("mij,mj->mi", ra[t], local))[face]
    edge = mode == 2
    pa[edge] = _support(ca[t], ha[t], ra[t], u, i, lam_a)[edge]
    pb = _support(cb[t], hb[t], rb[t], -u)
    pb[edge] = _support(cb[t], hb[t], rb[t], -u, j, lam_b)[edge]
    cb[t] += pa + gap[:, None] * u - pb


class OrientedBoxesCase(ConvexPairCase):
    name = "oriented_boxes"
    description = ("random oriented box pairs: overlap, signed distance and normal against the "
                   "Minkowski-difference hull")
    tags = ("collision", "queries", "sat", "exact")
    dim = 3
    params = ConvexPairCase.pair_params("cube")

    def draw(self, p, rng) -> dict:
        n = int(p["n"])
        half_a = np.exp(rng.uniform(np.log(0.05), np.log(1.0), (n, 3)))
        half_b = np.exp(rng.uniform(np.log(0.05), np.log(1.0), (n, 3)))
        rot_a, rot_b = _rotations(rng, n), _rotations(rng, n)
        centre_a = rng.uniform(-p["extent"], p["extent"], (n, 3))
        heading = rng.normal(size=(n, 3))
        heading /= np.linalg.norm(heading, axis=1)[:, None]
        reach = np.linalg.norm(half_a, axis=1) + np.linalg.norm(half_b, axis=1)
        centre_b = centre_a + (rng.uniform(0.0, 1.2, n) * reach)[:, None] * heading
        _touch(rng, centre_a, half_a, rot_a, centre_b, half_b, rot_b)
        eight = np.full(n, 8)
        a_pts, b_pts = corners(centre_a, half_a, rot_a), corners(centre_b, half_b, rot_b)
        out = {"part": BoxPairs(centre_a, half_a, rot_a, centre_b, half_b, rot_b),
               "a_pts": a_pts, "a_count": eight, "b_pts": b_pts, "b_count": eight}
        return out

    def sizes(self, d, idx) -> dict:
        """S the largest coordinate, l the shortest edge (2 h) of both boxes, the lever: the
        pair's bounding-box diagonal over l."""
        q = d["part"]
        feature = 2 * np.minimum(q.a_half[idx].min(1), q.b_half[idx].min(1))
        both = np.concatenate([d["a_pts"][idx], d["b_pts"][idx]], axis=1)
        span = np.linalg.norm(both.max(1) - both.min(1), axis=1)
        return {"scale": np.abs(both).max(axis=(1, 2)), "feature": feature,
                "lever": span / feature}

    def motion_scale(self, p) -> float:
        return 1.0  # m: the boxes' sizes, half extents 0.05-1 m


CASE = OrientedBoxesCase()
