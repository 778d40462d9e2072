"""pymunk's polygon-pair queries (adapters/pymunk_engine/groups/collision_polygons.py): closed
forms (square vs 45-degree square), a random batch against a brute-force oracle written here
(SAT over both polygons' edge normals for overlaps, least vertex-to-edge distance for misses),
Chipmunk's gradient switch below 1e-5 m, and the settings. pymunk is imported on purpose: CI
must have every engine (fail, never skip)."""
import math

import numpy as np
import pymunk  # noqa: F401  (fail, never skip, without the engine)

from refsim.registry import get_engine
from refsim.scene import Scene
from refsim.scene.queries import PolygonPairs

ENGINE = get_engine("pymunk")
EPS = np.finfo(float).eps
SQUARE = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
DIAMOND = math.sqrt(0.5) * np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])


def _answers(a_list, b_list):
    k = max(len(p) for p in a_list + b_list)
    pad = [np.vstack([p, np.repeat(p[:1], k - len(p), 0)]) for p in a_list + b_list]
    n = len(a_list)
    part = PolygonPairs(np.array(pad[:n]), [len(p) for p in a_list], np.array(pad[n:]),
                        [len(p) for p in b_list])
    sim = ENGINE.build(Scene(parts=(part,), dim=2), 1.0, "query", "")
    sim.step(1)
    obs = sim.observe()
    return sim, {k: obs[f"query.{k}"] for k in ("overlap", "distance", "normal")}


def test_square_against_45_degree_square_is_the_closed_form():
    """d = dx - 1/2 - sqrt(1/2), normal +x, for gaps and overlaps (shapes_collide's EPA depth,
    -0.207107 at dx = 1; point queries for misses). Within 4 eps of the coordinates: the
    inputs dx + sqrt(1/2) cos(t) are rounded once, Chipmunk subtracts and projects them."""
    dxs = [0.8, 1.0, 1.2, 1.5, 3.0]
    _, got = _answers([SQUARE] * len(dxs), [DIAMOND + [dx, 0.0] for dx in dxs])
    exact = np.array(dxs) - 0.5 - math.sqrt(0.5)
    np.testing.assert_allclose(got["distance"], exact, rtol=0, atol=4 * EPS * 3.0)
    np.testing.assert_allclose(got["normal"], [[1.0, 0.0]] * len(dxs), rtol=0, atol=4 * EPS)
    assert got["overlap"].tolist() == [1.0, 1.0, 1.0, 0.0, 0.0]


def _oracle(a, b):
    """Signed distance and normal A -> B of two convex counter-clockwise polygons."""
    depth, axis = np.inf, None
    for p, q, sign in ((a, b, 1.0), (b, a, -1.0)):
        e = np.roll(p, -1, 0) - p
        normals = np.stack([e[:, 1], -e[:, 0]], 1) / np.linalg.norm(e, axis=1)[:, None]
        for m in normals:
            overlap = (p @ m).max() - (q @ m).min()
            if overlap < depth:
                depth, axis = overlap, sign * m
    if depth >= 0:
        return -depth, axis
    best, normal = np.inf, None
    for p, q, sign in ((a, b, 1.0), (b, a, -1.0)):
        for v in q:
            for i in range(len(p)):
                s, e = p[i], p[(i + 1) % len(p)]
                t = np.clip((v - s) @ (e - s) / ((e - s) @ (e - s)), 0.0, 1.0)
                d = np.linalg.norm(v - s - t * (e - s))
                if d < best:
                    best, normal = d, sign * (v - s - t * (e - s)) / d
    return best, normal


def _polygon(rng, k):
    t = np.sort(rng.uniform(0, 2 * np.pi, k))
    return rng.uniform(-1, 1, 2) + rng.uniform(0.3, 1.0) * np.stack([np.cos(t), np.sin(t)], 1)


def test_random_pairs_match_the_brute_force_oracle():
    """300 random pairs of 3-8-gons (about 40 % overlapping): every distance and normal within
    round-off of the oracle (measured 4.4e-16 m and 2.6e-13; the bounds: 16 eps of the
    coordinates (|x| <= 2) for distances; for normals 1e-9, an edge direction rounded where
    edges are as short as 1e-4 of the coordinates), overlap = distance <= 0 exactly. Planted
    once: dropping the sign flip of A's vertex gradients gave normals 2.0 off; the deepest
    contact replaced by the last one gave distances 0.6 m off."""
    rng = np.random.default_rng(7)
    a = [_polygon(rng, rng.integers(3, 9)) for _ in range(300)]
    b = [_polygon(rng, rng.integers(3, 9)) for _ in range(300)]
    _, got = _answers(a, b)
    exact = [_oracle(p, q) for p, q in zip(a, b)]
    d_exact = np.array([e[0] for e in exact])
    n_exact = np.array([e[1] for e in exact])
    assert 0.2 < np.mean(d_exact < 0) < 0.8  # both branches exercised
    np.testing.assert_allclose(got["distance"], d_exact, rtol=0, atol=16 * EPS * 2.0)
    np.testing.assert_allclose(got["normal"], n_exact, rtol=0, atol=1e-9)
    assert np.array_equal(got["overlap"], (got["distance"] <= 0).astype(float))


def test_gradient_is_the_edge_normal_below_magic_epsilon():
    """Chipmunk's point_query returns the closest edge's normal, not the direction to the
    closest point, when the gap is <= 1e-5 m (MAGIC_EPSILON): two squares corner to corner
    along the diagonal answer the diagonal at a 2e-5 gap and an axis (45 degrees off) at 5e-6.
    The distance stays exact; settings declare the switch."""
    gaps = [2e-5, 5e-6]
    shifts = [0.5 + 0.5 + g / math.sqrt(2) for g in gaps]
    sim, got = _answers([SQUARE] * 2, [SQUARE + [s, s] for s in shifts])
    np.testing.assert_allclose(got["distance"], gaps, rtol=1e-9)  # 1e-9: the gap over |x| ~ 1
    diag = np.array([1.0, 1.0]) / math.sqrt(2)
    assert abs(got["normal"][0] @ diag - 1.0) < 1e-9
    assert abs(got["normal"][1] @ diag - math.sqrt(0.5)) < 1e-12  # an axis: cos 45 degrees
    assert sim.settings()["gradient_edge_normal_below"] == 1e-5


def test_settings_declare_how_each_answer_is_obtained():
    sim, _ = _answers([SQUARE], [SQUARE + [2.0, 0.0]])
    s = sim.settings()
    assert s["integrator"] == {"name": "query", "order": 0}
    assert s["poly_radius"] == 0.0 and s["collision_margin"] == 0.0
    assert "shapes_collide" in s["algorithm"] and "point_query" in s["algorithm"]
    assert "per pair" in s["loop"] and s["pymunk"] == pymunk.version
