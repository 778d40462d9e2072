"""pybullet's box-pair queries (adapters/pybullet_engine/groups/collision_boxes.py): the
collision margin's rounding (box vs 45-degree box), a random batch against a brute-force oracle
written here (SAT over the 15 axes for overlaps; vertex-to-box and edge-to-edge distances for
misses), both formulations. pybullet is imported on purpose: CI must have every engine."""
import itertools
import math

import numpy as np
import pybullet  # noqa: F401  (fail, never skip, without the engine)

from refsim.models.rigid_body import quaternion_to_matrix
from refsim.registry import get_engine
from refsim.scene import Scene
from refsim.scene.queries import BoxPairs

ENGINE = get_engine("pybullet")
EPS = np.finfo(float).eps
SIGNS = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))
EDGES = [(i, j) for i in range(8) for j in range(i + 1, 8) if np.sum(SIGNS[i] != SIGNS[j]) == 1]


def _answers(ca, ha, ra, cb, hb, rb, formulation):
    part = BoxPairs(ca, ha, ra, cb, hb, rb)
    sim = ENGINE.build(Scene(parts=(part,), dim=3), 1.0, "query", formulation)
    sim.step(1)
    obs = sim.observe()
    settings = sim.settings()
    sim.close()
    return settings, {k: obs[f"query.{k}"] for k in ("overlap", "distance", "normal")}


def _turn_z(n, angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.repeat(np.array([[[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]]), n, 0)


def test_box_against_45_degree_box_shows_the_margin():
    """Unit cubes, B turned 45 degrees about z at dx: exact d = dx - 1/2 - sqrt(1/2). GJK/EPA
    (closest_points) sees B's vertical edge rounded by the margin m = 0.001: d + m (sqrt 2 - 1)
    for gaps and overlaps alike (4e-4: MODELS.md's 0.793307); the box-box detector (default
    formulation, overlaps) is exact. Round-off bound 1e-12: a few eps of |x| <= 3 through
    Bullet's quaternion to matrix conversion."""
    dxs = np.array([0.8, 1.0, 2.0])
    n = len(dxs)
    ca, cb = np.zeros((n, 3)), np.stack([dxs, np.zeros(n), np.zeros(n)], 1)
    h, eye = np.full((n, 3), 0.5), np.repeat(np.eye(3)[None], n, 0)
    exact = dxs - 0.5 - math.sqrt(0.5)
    s, gjk = _answers(ca, h, eye, cb, h, _turn_z(n, math.pi / 4), "closest_points")
    m = s["collision_margin"]
    assert m == 0.001
    np.testing.assert_allclose(gjk["distance"], exact + m * (math.sqrt(2) - 1), rtol=0,
                               atol=1e-12)
    np.testing.assert_allclose(gjk["normal"], [[1.0, 0.0, 0.0]] * n, rtol=0, atol=1e-12)
    _, box = _answers(ca, h, eye, cb, h, _turn_z(n, math.pi / 4), "")
    np.testing.assert_allclose(box["distance"][:2], exact[:2], rtol=0, atol=1e-12)
    assert box["overlap"].tolist() == [1.0, 1.0, 0.0]


def _oracle(ca, ha, ra, cb, hb, rb):
    """Signed distance of two boxes (and the SAT normal A -> B of overlapping ones)."""
    va, vb = ca + (SIGNS * ha) @ ra.T, cb + (SIGNS * hb) @ rb.T
    axes = [ra[:, i] for i in range(3)] + [rb[:, i] for i in range(3)]
    axes += [np.cross(ra[:, i], rb[:, j]) for i in range(3) for j in range(3)]
    depth, normal = np.inf, None
    for m in axes:
        if np.linalg.norm(m) < 1e-9:
            continue
        m = m / np.linalg.norm(m) * (1.0 if (cb - ca) @ m >= 0 else -1.0)
        overlap = (va @ m).max() - (vb @ m).min()
        if overlap < depth:
            depth, normal = overlap, m
    if depth >= 0:
        return -depth, normal

    def to_box(p, c, h, r):
        q = np.abs((p - c) @ r) - h
        return np.linalg.norm(np.maximum(q, 0))

    best = min(min(to_box(v, cb, hb, rb) for v in va), min(to_box(v, ca, ha, ra) for v in vb))
    for i, j in EDGES:
        for k, l in EDGES:
            best = min(best, _segments(va[i], va[j], vb[k], vb[l]))
    return best, None


def _segments(p1, q1, p2, q2):
    """Distance between segments p1 q1 and p2 q2 (Ericson, Real-Time Collision Detection 5.1.9:
    the clamped closest parameters, parallel segments included)."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a, e, f, c, b = d1 @ d1, d2 @ d2, d2 @ r, d1 @ r, d1 @ d2
    den = a * e - b * b
    s = np.clip((b * f - c * e) / den, 0.0, 1.0) if den > 0 else 0.0
    t = (b * s + f) / e
    if t < 0:
        t, s = 0.0, np.clip(-c / a, 0.0, 1.0)
    elif t > 1:
        t, s = 1.0, np.clip((b - c) / a, 0.0, 1.0)
    return np.linalg.norm(p1 + s * d1 - p2 - t * d2)


def _batch(n=150, seed=3):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(2, n, 4))
    ra, rb = quaternion_to_matrix(q[0]), quaternion_to_matrix(q[1])
    ha, hb = rng.uniform(0.2, 1.0, (n, 3)), rng.uniform(0.2, 1.0, (n, 3))
    ca = rng.uniform(-50, 50, (n, 3))
    cb = ca + rng.uniform(-2, 2, (n, 3))
    exact = [_oracle(*x) for x in zip(ca, ha, ra, cb, hb, rb)]
    return (ca, ha, ra, cb, hb, rb), np.array([e[0] for e in exact]), [e[1] for e in exact]


def test_random_pairs_within_the_declared_margin_effect():
    """closest_points (GJK/EPA on boxes rounded by the margin m): every answer (gaps and
    depths) in [d*, d* + 2 m (sqrt 3 - 1)] (the rounded box lies inside the box, within
    m (sqrt 3 - 1) of it, per box), less 1e-12 below (round-off of |x| <= 52 m); overlap
    normals within 1e-9 of the SAT axis (EPA's face normal, rounded). Default (box-box detector for overlaps): misses the same; depths within
    5 % (fudge_factor 1.05 keeps a face axis over a shallower edge axis) plus 1e-4 (fudge2's
    1e-5 added to each |R_ij| of the edge axes, measured at most 2.7e-5 m in 1200 pairs); no
    false overlap or miss beyond the margin effect. Planted once: the normal not negated
    (pybullet's [7] is on B towards A) and the last contact instead of the deepest: each
    caught."""
    boxes, d_exact, n_exact = _batch()
    over = d_exact < 0
    assert 0.15 < over.mean() < 0.6
    s, gjk = _answers(*boxes, "closest_points")
    tol = s["distance_tolerance"]
    assert tol == 2 * 0.001 * (math.sqrt(3) - 1)
    err = gjk["distance"] - d_exact
    assert err.min() >= -1e-12 and err.max() <= tol + 1e-12
    for i in np.where(over)[0]:
        assert abs(gjk["normal"][i] @ n_exact[i] - 1.0) < 1e-9
    s, box = _answers(*boxes, "")
    err = box["distance"] - d_exact
    assert err[~over].min() >= -1e-12 and err[~over].max() <= tol + 1e-12
    assert np.all(np.abs(err[over]) <= s["depth_relative_tolerance"] * -d_exact[over] + 1e-4)
    clear = np.abs(d_exact) > tol
    assert np.array_equal(box["overlap"][clear], over[clear].astype(float))


def test_settings_declare_margin_and_algorithm():
    boxes, _, _ = _batch(n=20, seed=1)
    for form, word in (("", "getContactPoints"), ("closest_points", "getClosestPoints")):
        s, _ = _answers(*boxes, form)
        assert s["integrator"] == {"name": "query", "order": 0}
        assert word in s["algorithm"] and "per pair" in s["loop"]
        assert s["collision_margin"] == 0.001
