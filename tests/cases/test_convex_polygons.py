"""convex_polygons: the Minkowski-difference oracle against shapely (an independent library:
overlap and distance; it gives no depth or normal), the batch's mix, the refsim row, and the
planted defects the bounds catch (inputs rounded to float32, the normal's sign flipped, B's
edge normals left out of SAT)."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

from refsim_cases.collision.convex_polygons import CASE
from refsim.models.collision import sat
from refsim.run.job import Job, run_job

P = CASE.variant_params("default")


@pytest.fixture(scope="module")
def batch():
    return CASE._draw(P), CASE.exact_cached(P)


def _shapely(verts, count):
    return np.array([shapely.Polygon(v[:c]) for v, c in zip(verts, count)])


def test_oracle_agrees_with_shapely(batch):
    d, ex = batch
    a, b = _shapely(d["a_pts"], d["a_count"]), _shapely(d["b_pts"], d["b_count"])
    sure = np.abs(ex["distance"]) > P["margin"]
    np.testing.assert_array_equal(shapely.intersects(a, b)[sure], ex["overlap"][sure] > 0.5)
    apart = ex["overlap"] < 0.5
    gap = np.abs(shapely.distance(a, b)[apart] - ex["distance"][apart])
    # both exact algorithms in double: round-off of the coordinates (the case's bound per pair,
    # K eps S (1 + lever)); measured 2.2e-16 worst against bounds of 3.8e-14 and more
    assert np.all(gap <= ex["bound"][apart]), gap.max()


def test_batch_mixes_overlapping_apart_and_touching(batch):
    d, ex = batch
    assert 0.3 < ex["overlap"].mean() < 0.7
    near = np.abs(ex["distance"]) < 1e-3
    assert near.sum() > 0.15 * len(near)  # the touching share (20 %) and a few natural ones
    # the margin is far above the round-off: a pair outside it is one class for any correct
    # double-precision answer
    assert P["margin"] > 50 * ex["bound"].max()
    assert 0 < int(np.sum(np.abs(ex["distance"]) <= P["margin"])) < 0.05 * len(near)


def test_refsim_row_is_consistent():
    row = run_job(Job(CASE.name, "default", "refsim", "", "query", 1.0), repeats=0)
    assert row["status"] == "ok" and row["consistency"] == "consistent", row["consistency_reason"]
    assert row["false_negatives"] == row["false_positives"] == 0
    assert row["distance_err"] <= row["tolerance"]


def _verdict(answers, settings=None):
    ex = CASE.exact_cached(P)
    got = CASE.measure(P, answers, ex)
    bounds = CASE.bounds(P, settings or {"distance_tolerance": 0.0})
    return got, {k: got[k] <= b for k, (b, _) in bounds.items()}


def test_planted_float32_is_caught(batch):
    d, _ = batch
    q = d["part"]
    f32 = lambda x: np.asarray(x, np.float32).astype(float)  # noqa: E731
    got, ok = _verdict(sat.polygon_pairs(f32(q.a), q.a_count, f32(q.b), q.b_count))
    assert not ok["distance_err"] and got["distance_err"] > 1e-7, got


def test_planted_normal_sign_flip_is_caught(batch):
    d, _ = batch
    q = d["part"]
    ans = sat.polygon_pairs(q.a, q.a_count, q.b, q.b_count)
    got, ok = _verdict({**ans, "normal": -ans["normal"]})
    assert not ok["normal_err_deg"] and got["normal_err_deg"] == pytest.approx(180.0)
    assert all(ok[k] for k in ("distance_err", "false_negatives", "false_positives"))


def test_planted_missing_axis_family_is_caught(batch, monkeypatch):
    """SAT over A's edge normals only: B's axes never separate (false positives) nor give the
    depth."""
    d, _ = batch
    q = d["part"]
    monkeypatch.setattr(sat, "_separations", _only_a(sat._separations))
    got, ok = _verdict(sat.polygon_pairs(q.a, q.a_count, q.b, q.b_count))
    assert not ok["distance_err"] and not ok["false_positives"], got


def _only_a(separations):
    calls = []

    def patched(pa, pb):
        calls.append(1)
        s = separations(pa, pb)
        return s if len(calls) % 2 else np.full_like(s, -np.inf)
    return patched


def test_an_edge_normal_switch_near_touching_is_declared_not_hidden(batch):
    """settings["gradient_edge_normal_below"] (pymunk's 1e-5 m) unbounds the normals of the
    separated pairs closer than it (normal_err_deg 180) and no other: the far pairs' bound and
    the distance bound stay the plain ones (a sign flip is still caught there)."""
    _, ex = batch
    plain = CASE.bounds(P, {})
    switched = CASE.bounds(P, {"gradient_edge_normal_below": 1e-5})
    assert np.any((ex["overlap"] < 0.5) & (ex["distance"] > P["margin"]) & (ex["distance"] <= 1e-5))
    assert switched["normal_err_deg"][0] == 180.0
    for key in ("normal_err_far_deg", "distance_err", "false_negatives"):
        assert switched[key][0] == plain[key][0]
