"""oriented_boxes: the Minkowski-difference oracle on closed forms (a cube against a cube
turned 45 degrees about z: MODELS.md's (3 - sqrt 2)/2 and (1 - sqrt 2)/2; crossed edges;
corner to corner), the batch's mix, the refsim row, and the planted defects the bounds catch
(inputs rounded to float32, the normal's sign flipped, the 9 edge-edge axes left out)."""
from __future__ import annotations

import numpy as np
import pytest

from refsim_cases.collision._minkowski import oracle
from refsim_cases.collision.oriented_boxes import CASE, corners
from refsim.models.collision import sat
from refsim.run.job import Job, run_job

P = CASE.variant_params("default")
SQ2 = np.sqrt(2.0)


def _turn(axis, deg):
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    i, j = [k for k in range(3) if k != axis]
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


def _cubes(b_center, b_rot, a_rot=np.eye(3)):
    n = len(b_center)
    half = np.full((n, 3), 0.5)
    a = corners(np.zeros((n, 3)), half, np.repeat(a_rot[None], n, 0))
    b = corners(np.asarray(b_center, float), half, np.repeat(b_rot[None], n, 0))
    return oracle(a, np.full(n, 8), b, np.full(n, 8))


def _close(got, want, why):
    # Qhull's planes and the closed forms round differently: a few eps of the 3 m coordinates
    np.testing.assert_allclose(got, want, rtol=0, atol=64 * np.finfo(float).eps * 3, err_msg=why)


def test_oracle_on_closed_forms():
    x = np.array([2.0, 1.0])
    ex = _cubes(np.stack([x, 0 * x, 0 * x], 1), _turn(2, 45.0))
    _close(ex["distance"], [(3 - SQ2) / 2, (1 - SQ2) / 2], "cube vs 45-degree cube")
    _close(ex["normal"], [[1, 0, 0], [1, 0, 0]], "along x, from A to B")
    c = np.array([2.0, 1.3])
    ex = _cubes(np.stack([c, 0 * c, 0 * c], 1), _turn(1, 45.0), _turn(2, 45.0))
    _close(ex["distance"], c - SQ2, "crossed edges")
    ex = _cubes(np.array([[2.0, 2.0, 2.0]]), np.eye(3))
    _close(ex["distance"], [np.sqrt(3.0)], "corner to corner")
    _close(ex["normal"], [np.full(3, 1 / np.sqrt(3.0))], "diagonal")
    np.testing.assert_array_equal(ex["overlap"], [0.0])


@pytest.fixture(scope="module")
def batch():
    return CASE._draw(P), CASE.exact_cached(P)


def _answers(q, cast=lambda x: x, **kw):
    return sat.box_pairs(cast(q.a_center), cast(q.a_half), cast(q.a_rotation),
                         cast(q.b_center), cast(q.b_half), cast(q.b_rotation), **kw)


def test_batch_mixes_overlapping_apart_and_touching(batch):
    _, ex = batch
    assert 0.3 < ex["overlap"].mean() < 0.7
    near = np.abs(ex["distance"]) < 1e-3
    assert near.sum() > 0.15 * len(near)  # the touching share (20 %)
    # the margin is far above the round-off: a pair outside it is one class for any correct
    # double-precision answer
    assert P["margin"] > 50 * ex["bound"].max()
    assert 0 < int(np.sum(np.abs(ex["distance"]) <= P["margin"])) < 0.05 * len(near)


def test_refsim_row_is_consistent():
    row = run_job(Job(CASE.name, "default", "refsim", "", "query", 1.0), repeats=0)
    assert row["status"] == "ok" and row["consistency"] == "consistent", row["consistency_reason"]
    assert row["false_negatives"] == row["false_positives"] == 0
    assert row["distance_err"] <= row["tolerance"]


def _verdict(answers):
    got = CASE.measure(P, answers, CASE.exact_cached(P))
    return got, {k: got[k] <= b for k, (b, _) in CASE.bounds(P, {}).items()}


def test_planted_float32_is_caught(batch):
    f32 = lambda x: np.asarray(x, np.float32).astype(float)  # noqa: E731
    got, ok = _verdict(_answers(batch[0]["part"], f32))
    assert not ok["distance_err"] and got["distance_err"] > 1e-7, got


def test_planted_normal_sign_flip_is_caught(batch):
    ans = _answers(batch[0]["part"])
    got, ok = _verdict({**ans, "normal": -ans["normal"]})
    assert not ok["normal_err_deg"] and got["normal_err_deg"] == pytest.approx(180.0)
    assert all(ok[k] for k in ("distance_err", "false_negatives", "false_positives"))


def test_planted_missing_edge_axes_are_caught(batch):
    """Only the 6 face axes (every cross product skipped): edge-edge separations are missed
    (false positives) and edge-edge depths overestimated."""
    got, ok = _verdict(_answers(batch[0]["part"], parallel_sin=np.inf))
    assert not ok["distance_err"] and not ok["false_positives"], got
    assert not ok["normal_err_deg"], got


def test_large_variant_checks_a_seeded_sample():
    """10^5 pairs answered, 5000 of them (seeded, sorted, distinct) compared with the oracle:
    the default batch (1000) is compared whole."""
    p = CASE.variant_params("large")
    idx = CASE.checked(p)
    assert len(idx) == 5000 == len(np.unique(idx)) and np.all(np.diff(idx) > 0)
    assert idx[0] >= 0 and idx[-1] < p["n"]
    np.testing.assert_array_equal(CASE.checked(P), np.arange(int(P["n"])))


def test_near_parallel_edges_lose_nothing():
    """B turned 1e-7 to 1e-5 rad from A (random poses): three of the nine edge pairs are within
    PARALLEL_SIN = 1e-6 of parallel or near it; SAT still agrees with the oracle to round-off
    (measured 5.6e-16 m: the sliver faces those pairs make never hold the least depth by more
    than round-off here)."""
    rng = np.random.default_rng(0)
    n = 200
    theta = np.exp(rng.uniform(np.log(1e-7), np.log(1e-5), n))
    rot_a = np.stack([_turn(2, rng.uniform(0, 360)) @ _turn(0, rng.uniform(0, 360))
                      for _ in range(n)])
    deg = np.degrees(theta)
    rot_b = np.stack([r @ _turn(0, t) @ _turn(1, t) @ _turn(2, -t) for r, t in zip(rot_a, deg)])
    ha, hb = rng.uniform(0.2, 1, (n, 3)), rng.uniform(0.2, 1, (n, 3))
    ca, cb = np.zeros((n, 3)), rng.normal(size=(n, 3)) * 0.8
    out = sat.box_pairs(ca, ha, rot_a, cb, hb, rot_b)
    ex = oracle(corners(ca, ha, rot_a), np.full(n, 8), corners(cb, hb, rot_b), np.full(n, 8))
    assert 0.2 < ex["overlap"].mean() < 0.9
    _close(out["distance"], ex["distance"], "near-parallel boxes")
    np.testing.assert_array_equal(out["overlap"], ex["overlap"])


def test_bounds_read_the_engines_distance_tolerance(batch):
    """settings["distance_tolerance"] widens the distance bound by itself, allows the pairs
    within it of touching to be misclassified, and leaves the far pairs' normal bound finite
    (the near pairs' normals are then unbounded: 180 deg)."""
    _, ex = batch
    tol = 1e-4
    plain, wide = CASE.bounds(P, {}), CASE.bounds(P, {"distance_tolerance": tol})
    assert wide["distance_err"][0] == plain["distance_err"][0] + tol
    within = int(np.sum((np.abs(ex["distance"]) > P["margin"]) & (np.abs(ex["distance"]) <= tol)))
    assert wide["false_negatives"][0] == wide["false_positives"][0] == within > 0
    assert plain["false_negatives"][0] == 0
    assert wide["normal_err_deg"][0] == 180.0
    assert plain["normal_err_far_deg"][0] < wide["normal_err_far_deg"][0] < 10.0
    ans = _answers(batch[0]["part"])
    got = CASE.measure(P, {**ans, "normal": -ans["normal"]}, ex)
    assert got["normal_err_far_deg"] > wide["normal_err_far_deg"][0]  # a flip still caught


def test_oracle_flags_a_tie_between_planes():
    """Aligned unit cubes offset (0.5, 0.5, 0): the depths along x and y are both 0.5, the
    normal is either axis: normal_gap 0 (the case counts the pair ambiguous); offset (0.5,
    0.3, 0): y is deeper by 0.2, the normal is x, the gap 0.2."""
    ex = _cubes(np.array([[0.5, 0.5, 0.0], [0.5, 0.3, 0.0]]), np.eye(3))
    _close(ex["distance"], [-0.5, -0.5], "depth 0.5 along x")
    _close(ex["normal_gap"], [0.0, 0.2], "the second plane's extra depth")
    _close(ex["normal"][1], [1.0, 0.0, 0.0], "x, from A to B")


def test_bounds_read_the_depth_relative_tolerance(batch):
    """settings["depth_relative_tolerance"] r allows r x depth more on overlapping pairs: the
    distance bound grows by r x the deepest pair's depth (to round-off); alone it allows no
    misclassification (an error r x depth never reaches a depth) and leaves the far pairs'
    normals unbounded (5 % of a 1 m depth is past the 1e-3 m the far class keeps)."""
    _, ex = batch
    rel = 0.05
    plain, wide = CASE.bounds(P, {}), CASE.bounds(P, {"depth_relative_tolerance": rel})
    deepest = float(np.max(-ex["distance"]))
    grown = wide["distance_err"][0] - plain["distance_err"][0]
    assert abs(grown - rel * deepest) <= plain["distance_err"][0]  # round-off terms differ
    assert wide["false_negatives"][0] == 0 and wide["normal_err_far_deg"][0] == 180.0


def test_one_flipped_normal_is_caught_per_pair_under_a_loose_declared_tolerance(batch):
    """An engine declaring pybullet's box-box tolerances (1.46e-3 m, 5 % of each depth) makes
    the batch-wide normal bound 180 deg (a deep pair's allowance over a short feature), so the
    batch maxima alone would pass any normal; each pair's own bound still catches ONE normal
    flipped on a pair the tolerance leaves well defined."""
    settings = {"distance_tolerance": 1.46e-3, "depth_relative_tolerance": 0.05,
                "feature_shift": 2e-3 * 3 ** 0.5}  # pybullet's declared set (margin 1e-3)
    ans = _answers(batch[0]["part"])
    ex = CASE.exact_cached(P)
    assert CASE.bounds(P, settings)["normal_err_deg"][0] == 180.0
    assert CASE.answer_checks(P, ans, ex, settings) == []
    allowed, turn = CASE._pair_bounds(P, ex, settings)
    sure, normal_ok, _ = CASE._classes(P, ex)
    k = int(np.flatnonzero(normal_ok & (ex["normal_gap"] > allowed) & (turn < 10))[0])
    flipped = ans["normal"].copy()
    flipped[ex["index"][k]] *= -1
    reasons = CASE.answer_checks(P, {**ans, "normal": flipped}, ex, settings)
    assert len(reasons) == 1 and reasons[0].startswith("1 pairs' normals"), reasons
