"""Random convex polygon pairs (2D) against the Minkowski-difference oracle (issue 28, case 1;
slide 001's separating axes).

The batch (seeded): n pairs of convex polygons of 3-12 vertices on ellipses (sizes 0.1-2 m,
aspect ratios 0.2-1, random turns), A's centre uniform in [-L, L]^2, B's at 0-1.2 times the
sum of the two sizes in a random direction: about 58 % overlapping, the rest apart; then a
share of 20 % moved to touch at a signed gap log-uniform in +-[1e-10, 1e-3] m, vertex to vertex
or vertex to edge (`_touch`). Exact answers (overlap, signed distance, normal from A to B, as
refsim.scene.queries states them) from the hull of {b_j - a_i} (cases/collision/_minkowski.py,
Qhull: not the algorithm under test); shapely checks its overlap and distance
(tests/cases/test_convex_polygons.py).

Measures (cases/collision/_minkowski.ConvexPairCase): `distance_err` (m, the tolerance
column) max |d - d*| over every pair; `normal_err_deg` the largest angle to n* over the pairs
where n* is defined (angles by atan2(|n x n*|, n.n*): arccos cannot tell below 2e-8 rad);
`normal_err_far_deg` the same over the pairs 1e-3 m or more from touching and from a second
plane's depth (an engine's declared tolerance leaves its bound finite there, as it cannot
for a pair 1e-9 m apart); `false_negatives` / `false_positives` on the overlap flag; `ambiguous`
the pairs left out: |d*| <= margin (1e-9 m: the flag is round-off there) or, overlapping, a
facet of another plane within the margin of the deepest (the normal is round-off there).

Bounds. Per pair B_i = K eps S (1 + lever), K = 16: every coordinate is rounded at its size S
(the pair's largest |coordinate|, up to L + 2 m) and a normal built from an edge of length l
(the shortest of both polygons) is turned by ~eps S / l, moving the projection of a point a
lever D (the pair's extent) away by D/l times as much; distance_err <= max B_i (1.4e-11 m on the
default batch) plus the engine's declared terms, settings keys (absent: 0): "distance_tolerance"
(m, on every answer: a collision margin kept in the answers, an iteration tolerance) and
"depth_relative_tolerance" (of each overlapping pair's depth: a collider that prefers face
axes): E_i = B_i + tol + rel depth_i, distance_err <= max E_i. normal_err_deg <= max over the
compared pairs of E_i / l' rad, l' = l, and |d*| where apart (a closest-point direction turns by
the points' error over their distance); normal_err_far_deg the same over the far pairs (180 once
2 (E_i - B_i) >= 1e-3 m on one of them). False negatives and positives: 0, or with declared
terms the number of pairs within E_i - B_i of touching. An engine whose normal near touching
is an edge's, not the closest points' direction, declares the gap below which it is so
("gradient_edge_normal_below", m): those pairs' normal bound is 180 deg (the far ones keep
theirs). Measured on refsim: distance_err 2.2e-16
m (max B_i / err = 6.5e4: the lever term is the worst case, not the typical one), normal_err_deg
5.4e-7 (a pair 1e-9 m apart; bound 0.056), normal_err_far_deg 1.9e-12 (bound 9.9e-8).
The large variant (10^5 pairs) compares a seeded sample of `checked` = 5000 pairs with the
oracle (Qhull's ~0.1 ms a pair: 10 s a row for all); the engine answers the whole batch.

Planted once (the default batch, measured against these bounds): inputs rounded to float32:
distance_err 8.3e-7 m, 12 false negatives, 22 false positives, normals 180 deg off (far
pairs: 5.9e-4 deg); the normal's sign flipped: 180 deg, the rest unchanged; only A's edge
normals (B's axes dropped): distance_err 1.01 m, 40 false positives, 173 deg; A scaled 0.1 %
about its first vertex: distance_err 3.6e-3 m, 45 false positives. SAT's largest separation
as the distance of separated pairs (no vertex-edge pass): up to 0.039 m (11 %) short, on 16 %
of them.
"""
from __future__ import annotations

import numpy as np

from refsim.scene.queries import PolygonPairs

from ._minkowski import ConvexPairCase

K_MAX = 12  # vertices per polygon: 3..K_MAX
TOUCH_SHARE = 0.2  # pairs moved to a signed distance log-uniform in [TOUCH_LOW, TOUCH_HIGH] m
TOUCH_LOW, TOUCH_HIGH = 1e-10, 1e-3


def _polygons(rng, n, count):
    """n convex counter-clockwise polygons, vertices on an ellipse (size log-uniform in [0.1,
    2] m, aspect in [0.2, 1], random angle), at angles with gaps uniform in [0.3, 1] (then
    scaled to 2 pi): (vertices (n, K_MAX, 2) about the origin, zeros past count)."""
    gaps = rng.uniform(0.3, 1.0, (n, K_MAX))
    real = np.arange(K_MAX)[None, :] < count[:, None]
    gaps = np.where(real, gaps, 0.0)
    phi = 2 * np.pi * np.cumsum(gaps, axis=1) / gaps.sum(axis=1)[:, None]
    phi += rng.uniform(0, 2 * np.pi, (n, 1))
    size = np.exp(rng.uniform(np.log(0.1), np.log(2.0), n))
    aspect = rng.uniform(0.2, 1.0, n)
    local = np.stack([size[:, None] * np.cos(phi), (size * aspect)[:, None] * np.sin(phi)], -1)
    theta = rng.uniform(0, 2 * np.pi, n)
    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    world = np.stack([c * local[..., 0] - s * local[..., 1],
                      s * local[..., 0] + c * local[..., 1]], -1)
    return np.where(real[..., None], world, 0.0), size


class ConvexPolygonsCase(ConvexPairCase):
    name = "convex_polygons"
    description = ("random convex polygon pairs (3-12 vertices): overlap, signed distance and "
                   "normal against the Minkowski-difference hull")
    tags = ("collision", "queries", "sat", "exact")
    dim = 2
    params = ConvexPairCase.pair_params("square")

    def draw(self, p, rng) -> dict:
        n = int(p["n"])
        a_count, b_count = rng.integers(3, K_MAX + 1, n), rng.integers(3, K_MAX + 1, n)
        a, size_a = _polygons(rng, n, a_count)
        b, size_b = _polygons(rng, n, b_count)
        centre = rng.uniform(-p["extent"], p["extent"], (n, 2))
        heading = rng.uniform(0, 2 * np.pi, n)
        gap = rng.uniform(0.0, 1.2, n) * (size_a + size_b)
        offset = gap[:, None] * np.stack([np.cos(heading), np.sin(heading)], -1)
        a = np.where(np.arange(K_MAX)[None, :, None] < a_count[:, None, None], a + centre[:, None],
                     0.0)
        b_off = centre + offset
        b = np.where(np.arange(K_MAX)[None, :, None] < b_count[:, None, None],
                     b + b_off[:, None], 0.0)
        _touch(rng, a, a_count, b, b_count)
        out = {"part": PolygonPairs(a, a_count, b, b_count), "a_pts": a, "a_count": a_count,
               "b_pts": b, "b_count": b_count}
        return out

    def sizes(self, d, idx) -> dict:
        return _levers(d["a_pts"][idx], d["a_count"][idx], d["b_pts"][idx], d["b_count"][idx])

    def motion_scale(self, p) -> float:
        return 1.0  # m: the polygons' sizes, 0.1-2 m


def _touch(rng, a, a_count, b, b_count) -> None:
    """Move a share TOUCH_SHARE of the B polygons (in place) to touch A at a signed gap g
    log-uniform in +-[TOUCH_LOW, TOUCH_HIGH] m along a unit u: B's support point along -u
    (a vertex) is put at g u from A's support point along u, half of them with u random (A's
    support is then a vertex: vertex to vertex), half with u one of A's edge normals and A's
    point inside that edge (vertex to edge). The plane normal to u through A's point separates
    them when g > 0: the distance is g (the two points are g apart); g < 0: B's vertex is in A,
    the depth at most |g|. The exact answers are the oracle's all the same."""
    n = len(a)
    touch = np.nonzero(rng.random(n) < TOUCH_SHARE)[0]
    m = len(touch)
    gap = np.exp(rng.uniform(np.log(TOUCH_LOW), np.log(TOUCH_HIGH), m))
    gap *= np.where(rng.random(m) < 0.5, -1.0, 1.0)
    real_a = np.arange(K_MAX)[None, :] < a_count[touch, None]
    real_b = np.arange(K_MAX)[None, :] < b_count[touch, None]
    at, bt = a[touch], b[touch]
    phi = rng.uniform(0, 2 * np.pi, m)
    u = np.stack([np.cos(phi), np.sin(phi)], -1)
    pa = at[np.arange(m), np.argmax(np.where(real_a, np.einsum("mkd,md->mk", at, u), -np.inf), 1)]
    edge = rng.integers(0, K_MAX, m) % a_count[touch]  # vertex to edge: A's edge i, outward normal
    nxt = np.where(edge + 1 < a_count[touch], edge + 1, 0)
    e = at[np.arange(m), nxt] - at[np.arange(m), edge]
    on_edge = rng.random(m) < 0.5
    u[on_edge] = (np.stack([e[:, 1], -e[:, 0]], -1) / np.linalg.norm(e, axis=1)[:, None])[on_edge]
    pa[on_edge] = (at[np.arange(m), edge] + rng.uniform(0.1, 0.9, m)[:, None] * e)[on_edge]
    pb = bt[np.arange(m), np.argmin(np.where(real_b, np.einsum("mkd,md->mk", bt, u), np.inf), 1)]
    shift = pa + gap[:, None] * u - pb
    b[touch] = np.where(real_b[..., None], bt + shift[:, None], 0.0)


def _levers(a, a_count, b, b_count) -> dict:
    """Per pair: S the largest coordinate, the shortest edge l of both polygons and the lever
    (both polygons' diameter bound |a_i - b_j| max) / l."""
    idx = np.arange(K_MAX)[None, :]
    out = {}
    edges = []
    for v, cnt in ((a, a_count), (b, b_count)):
        nxt = np.where(idx + 1 < cnt[:, None], idx + 1, 0)
        e = v[np.arange(len(v))[:, None], nxt] - v
        edges.append(np.where(idx < cnt[:, None], np.hypot(e[..., 0], e[..., 1]), np.inf))
    feature = np.minimum(edges[0].min(1), edges[1].min(1))
    real_a = idx[..., None] < a_count[:, None, None]
    real_b = idx[..., None] < b_count[:, None, None]
    lo = np.minimum(np.where(real_a, a, np.inf).min(1), np.where(real_b, b, np.inf).min(1))
    hi = np.maximum(np.where(real_a, a, -np.inf).max(1), np.where(real_b, b, -np.inf).max(1))
    out["scale"] = np.maximum(np.abs(lo), np.abs(hi)).max(1)
    out["feature"] = feature
    out["lever"] = np.linalg.norm(hi - lo, axis=1) / feature
    return out


CASE = ConvexPolygonsCase()
