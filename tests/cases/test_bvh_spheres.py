"""bvh_spheres: the brute-force oracle, the measures (each defect of an answer counted where it
belongs, round-off ties and touching pairs not), the cube's side for the stated overlaps per
query, and the in-house BVH's rows (both splits) through the harness."""
import numpy as np
import pytest

from refsim.case import EPS
from refsim.registry import get_case
from refsim.run.job import Job, run_job
from refsim_cases.collision.bvh_spheres import K_ROUNDING, side

CASE = get_case("bvh_spheres")


def _params(**kw):
    return CASE.validate({**CASE.variant_params("default"), **kw})


def test_oracle_equals_the_plain_formula():
    """Every pair classified from the (M, N, 3) differences written out once."""
    p = _params(n=300, m=200)
    exact = CASE.exact(p)
    pc, pr = exact["prim_center"], exact["prim_radius"]
    qc, qr = exact["query_center"], exact["query_radius"]
    dist = np.linalg.norm(qc[:, None, :] - pc[None], axis=2)
    gap = dist - qr[:, None] - pr[None]
    margin = K_ROUNDING * EPS * (np.linalg.norm(qc, axis=1)[:, None]
                                 + np.linalg.norm(pc, axis=1)[None] + qr[:, None] + pr[None])
    q, i = np.nonzero(gap <= -margin)
    np.testing.assert_array_equal(exact["sure_keys"], q * 300 + i)
    assert len(exact["ambiguous_keys"]) == int(np.sum(np.abs(gap) < margin)) == 0
    value = dist - pr[None]
    # the least value: two summation orders of |c_q - c_p|, within the case's own round-off
    # bound on two computations of it
    np.testing.assert_allclose(exact["nearest_distance"], value.min(axis=1), rtol=0,
                               atol=CASE.bounds(p, {})["nearest_err"][0])
    assert np.mean(exact["nearest"] == value.argmin(axis=1)) == 1.0
    # the grazing share: the first 20 queries within 1e-3 (r_q + r_p) <= 2e-3 m of touching
    assert np.all(np.abs(gap[:20]).min(axis=1) <= 2e-3)


def _answers(exact):
    return {"pairs": exact["pairs"].copy(), "nearest": exact["nearest"].copy(),
            "nearest_distance": exact["nearest_distance"].copy()}


def test_measures_count_each_defect():
    p = _params(n=300, m=200)
    exact = CASE.exact(p)
    clean = CASE.measure(p, _answers(exact), exact)
    assert clean == {"false_negatives": 0, "false_positives": 0, "nearest_err": 0.0,
                     "nearest_index_mismatch": 0, "ambiguous": 0}
    ans = _answers(exact)
    ans["pairs"] = ans["pairs"][1:]  # one pair left out
    assert CASE.measure(p, ans, exact)["false_negatives"] == 1
    ans = _answers(exact)
    far = np.setdiff1d(np.arange(300), exact["pairs"][exact["pairs"][:, 0] == 0, 1])[0]
    ans["pairs"] = np.vstack([ans["pairs"], [0, far], ans["pairs"][:1], [0, 300], [-1, 0]])
    assert CASE.measure(p, ans, exact)["false_positives"] == 4  # apart, twice, 2 out of range
    ans = _answers(exact)
    ans["nearest"][3] = (ans["nearest"][3] + 1) % 300
    assert CASE.measure(p, ans, exact)["nearest_index_mismatch"] == 1
    ans = _answers(exact)
    ans["nearest_distance"][5] += 1e-9
    got = CASE.measure(p, ans, exact)["nearest_err"]
    bound = CASE.bounds(p, {})["nearest_err"][0]
    assert got == pytest.approx(1e-9, rel=1e-6) and bound < 1e-12 < got
    ans = _answers(exact)
    ans["nearest_distance"] = ans["nearest_distance"][:-1]  # a batch answered short
    assert CASE.measure(p, ans, exact)["nearest_index_mismatch"] == 200


def test_touching_pairs_and_ties_are_not_counted():
    """A hand-made batch: query 0 at (0, 1.5, 0) overlaps nothing; query 1 at (0, 5, 0) is
    equidistant from primitives 1 and 2 (mirror images about x = 0: the same operations give
    the same value, sqrt(29) - 0.5); pair (1, 0) stands for one the oracle found, pair (0, 0)
    for one within round-off of touching (ambiguous): answered or not, neither is counted."""
    exact = {"prim_center": np.array([[0.0, 0, 0], [2.0, 0, 0], [-2.0, 0, 0]]),
             "prim_radius": np.array([0.1, 0.5, 0.5]),
             "query_center": np.array([[0.0, 1.5, 0], [0.0, 5.0, 0]]),
             "sure_keys": np.array([3]), "ambiguous_keys": np.array([0]),
             "nearest": np.array([0.0, 1.0]),
             "nearest_distance": np.array([1.4, np.sqrt(29.0) - 0.5])}
    p = {"n": 3, "m": 2}
    for pairs, other in (([[1, 0]], 1.0), ([[0, 0], [1, 0]], 2.0)):
        got = CASE.measure(p, {"pairs": np.array(pairs, float), "nearest": [0.0, other],
                               "nearest_distance": exact["nearest_distance"]}, exact)
        assert got == {"false_negatives": 0, "false_positives": 0, "nearest_err": 0.0,
                       "nearest_index_mismatch": 0, "ambiguous": 1}
    got = CASE.measure(p, {"pairs": np.zeros((0, 2)), "nearest": [1.0, 0.0],
                           "nearest_distance": exact["nearest_distance"]}, exact)
    assert (got["false_negatives"], got["nearest_index_mismatch"]) == (1, 2)


def test_cube_side_gives_the_stated_overlaps_per_query():
    """Away from the faces (2 r_max), a query overlaps pairs_per_query primitives on average:
    the side's moments E[(r_q + r_p)^3] of the log-uniform radii. Counts are Poisson-like
    (sd 2 at mean 4): within 5 standard errors of the mean over the interior queries."""
    p = _params(n=5000, m=2000, grazing=0.0)
    exact = CASE.exact(p)
    half = 0.5 * side(p)
    inner = np.all(np.abs(exact["query_center"]) < half - 2 * 10 * p["r_min"], axis=1)
    counts = np.bincount(exact["sure_keys"] // 5000, minlength=2000)[inner]
    se = counts.std() / np.sqrt(len(counts))
    assert len(counts) > 500 and abs(counts.mean() - p["pairs_per_query"]) < 5 * se


@pytest.mark.parametrize("split", ["morton", "median"])
def test_in_house_rows_are_consistent_with_zero_false_negatives(split):
    row = run_job(Job(CASE.name, "default", "refsim", split, "query", 1.0), repeats=0)
    assert row["status"] == "ok", row["reason"]
    assert row["consistency"] == "consistent", row["consistency_reason"]
    assert row["false_negatives"] == row["false_positives"] == 0
    assert row["nearest_index_mismatch"] == 0 and row["nearest_err"] <= 1e-13
    assert row["queries"] == 1000
