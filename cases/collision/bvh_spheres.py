"""Overlap and nearest queries over N random spheres against brute force (issue 28, case 3;
slide 001's bounding volume hierarchies): a BVH (or any broad phase) must miss no pair.

A seeded batch: N primitive spheres and M query spheres, centres uniform in a cube of side L,
radii log-uniform over a decade [r_min, 10 r_min] (both sets). L grows as N^(1/3), so that a
query overlaps `pairs_per_query` primitives on average at every N (L^3 = N (4 pi / 3)
E[(r_q + r_p)^3] / pairs_per_query, the moments of the log-uniform law exact; the cube's faces
lower it a little): the per-query work of a good tree grows as log N, its build as N log N.
Answers (refsim.scene.queries, BvhQueries): every (query, primitive) pair with |c_q - c_p| <=
r_q + r_p, each query centre's nearest primitive surface (least |c_q - c_p| - r_p) and that
distance. The oracle is brute force over all M N pairs, vectorised in chunks of queries.

Round-off: a pair's gap g = |c_q - c_p| - (r_q + r_p) is computed by the oracle and by the
engine each with an error of a few eps of its terms; pairs with |g| < m, m = K eps (|c_q| +
|c_p| + r_q + r_p), K = 8 (four eps for each side's subtraction, squares, sum, root and radii
sum), are ambiguous: neither a false negative if missed nor a false positive if answered
(column `ambiguous` counts them; none at the seeds here). The same margin makes a nearest
index that differs from the oracle's a tie, not a mismatch, when its value is within m of the
least (m from the two primitives' terms).

Measures: `false_negatives` (the tolerance column; bound 0) pairs overlapping by more than m
that the engine left out; `false_positives` (bound 0) answered pairs that are apart by more
than m, out of range, or listed twice; `nearest_err` (m) max |d - d*| of the answered nearest
distance, bound K eps max(|c_q| + |c_p*| + r_p*); `nearest_index_mismatch` (bound 0) queries
whose answered index is not the oracle's and not a tie. Variants: default N = 1e3 (M = 1e3
everywhere); n1e4 and n1e5 by name (`refsim bench collision` times the BVH over the same
batches and fits its cost exponents).

A share `grazing` (10 %) of the queries is placed at a gap g from a random primitive, |g| /
(r_q + r_p) log-uniform in [1e-12, 1e-3], either sign, half of them along a coordinate axis
(the contact at the sphere's extreme point, often its leaf box's face): pairs decided far
below the spheres' size, where a coarse test or a shrunken box shows.

Planted once by hand on the refsim engine (the model patched, default variant, 3632 pairs;
morton / median): the sphere test at the leaves in float32: 3 / 3 false negatives, 16 / 19
false positives; the nearest values in float32: nearest_err 1.2e-7 m (bound 2.8e-14); the
query radius dropped from the node test: 1054 / 800 pairs missed; the query radius 1e-6 low
in the node test: 3 / 1 missed; a node's lower bound from its sphere box alone (0 where c_q
is inside a sphere): 212 / 204 index mismatches (nearest_err inf: the candidate pruned); no
round-off pad on the boxes: nothing here (no pair of the batch within a few ulps of
touching; tests/models/test_collision_bvh.py's ulp-touching set catches it).
"""
from __future__ import annotations

import numpy as np

from refsim.case import EPS, Param
from refsim.query import QueryCase
from refsim.scene import Scene
from refsim.scene.queries import BvhQueries

K_ROUNDING = 8
GRAZING_GAPS = (1e-12, 1e-3)  # |gap| / (r_q + r_p) of the grazing queries
CHUNK = 200_000  # (query, primitive) pairs per chunk of the brute force: 1.6 MB arrays


def _log_uniform_moment(k, lo, hi):
    """E[r^k] of r log-uniform on [lo, hi]."""
    return (hi ** k - lo ** k) / (k * np.log(hi / lo))


def side(p) -> float:
    """The cube's side L for `pairs_per_query` overlaps per query on average."""
    lo, hi = p["r_min"], 10.0 * p["r_min"]
    m1, m2, m3 = (_log_uniform_moment(k, lo, hi) for k in (1, 2, 3))
    reach3 = 2.0 * m3 + 6.0 * m1 * m2  # E[(a + b)^3], a and b independent, same law
    return float((p["n"] * 4.0 * np.pi / 3.0 * reach3 / p["pairs_per_query"]) ** (1.0 / 3.0))


class BvhSpheresCase(QueryCase):
    name = "bvh_spheres"
    description = ("overlap pairs and nearest surfaces of M query spheres among N random "
                   "spheres against brute force (a BVH must miss no pair)")
    tags = ("collision", "queries", "bvh", "exact")
    answers = ("pairs", "nearest", "nearest_distance")
    measures = {"false_negatives": ("pairs", "overlapping pairs (beyond round-off) left out"),
                "false_positives": ("pairs", "answered pairs apart beyond round-off, out of "
                                             "range or repeated"),
                "nearest_err": ("m", "max |d - d*| of the nearest surface distance"),
                "nearest_index_mismatch": ("queries", "nearest index not the oracle's and "
                                                      "not a tie within round-off"),
                "ambiguous": ("pairs", "pairs within round-off of touching (not judged)")}
    params = {
        "n": Param(1000, 1, 1e6, "primitive spheres N"),
        "m": Param(1000, 1, 1e6, "query spheres M"),
        "seed": Param(1, 0, 2 ** 31, "random seed"),
        "r_min": Param(0.1, 1e-6, 1e3, "least radius (m); radii log-uniform up to 10 r_min",
                       low_inclusive=False),
        "grazing": Param(0.1, 0.0, 1.0, "share of the queries placed at a tiny gap from a "
                                        "primitive"),
        "pairs_per_query": Param(4.0, 0.01, 1e3, "mean overlaps per query (sets the cube)",
                                 low_inclusive=False),
    }
    variants = {"default": {}, "n1e4": {"n": 1e4}, "n1e5": {"n": 1e5}}
    default_variants = quick_variants = ("default",)

    # -- the batch ------------------------------------------------------------------------------
    def batch(self, p) -> int:
        return int(p["m"])

    def _draw(self, p) -> dict:
        rng = np.random.default_rng(int(p["seed"]))
        n, m, half = int(p["n"]), int(p["m"]), 0.5 * side(p)
        lo, hi = np.log(p["r_min"]), np.log(10.0 * p["r_min"])
        d = {"prim_center": rng.uniform(-half, half, (n, 3)),
             "prim_radius": np.exp(rng.uniform(lo, hi, n)),
             "query_center": rng.uniform(-half, half, (m, 3)),
             "query_radius": np.exp(rng.uniform(lo, hi, m))}
        # grazing queries: at gap g from a random primitive, |g| / (r_q + r_p) log-uniform in
        # GRAZING_GAPS, either sign: pairs decided far below the spheres' size
        k = int(round(p["grazing"] * m))
        prim = rng.integers(0, n, k)
        reach = d["query_radius"][:k] + d["prim_radius"][prim]
        gap = reach * np.exp(rng.uniform(*np.log(GRAZING_GAPS), k)) * rng.choice([-1, 1], k)
        u = rng.normal(size=(k, 3))
        u /= np.linalg.norm(u, axis=1)[:, None]
        # half along an axis: the contact at a sphere's extreme point, often its leaf box's face
        axis = np.eye(3)[rng.integers(0, 3, k)] * rng.choice([-1.0, 1.0], (k, 1))
        u[: k // 2] = axis[: k // 2]
        d["query_center"][:k] = d["prim_center"][prim] + (reach + gap)[:, None] * u
        return d

    def scene(self, p):
        return Scene(parts=(BvhQueries(**self._draw(p)),), dim=3)

    # -- answers --------------------------------------------------------------------------------
    def exact(self, p) -> dict:
        """Brute force over every (query, primitive) pair, in chunks of queries."""
        d = self._draw(p)
        pc, pr, qc, qr = (d[k] for k in ("prim_center", "prim_radius", "query_center",
                                         "query_radius"))
        n, m = len(pc), len(qc)
        pn, qn = np.linalg.norm(pc, axis=1), np.linalg.norm(qc, axis=1)
        sure, ambiguous = [], []
        nearest, distance = np.empty(m, np.int64), np.empty(m)
        step = max(1, CHUNK // n)
        buffers = np.empty((2, min(step, m), n))
        for a in range(0, m, step):  # chunks of queries: memory, not a loop over pairs
            b = min(m, a + step)
            dist, part = buffers[0][: b - a], buffers[1][: b - a]
            for k in range(3):  # |c_q - c_p|^2 axis by axis, in place
                np.subtract(qc[a:b, k, None], pc[None, :, k], out=part)
                np.square(part, out=part)
                if k:
                    np.add(dist, part, out=dist)
                else:
                    dist, part = part, dist
            np.sqrt(dist, out=dist)
            value = np.subtract(dist, pr, out=dist)  # the nearest surface's distance
            nearest[a:b] = np.argmin(value, axis=1)
            distance[a:b] = value[np.arange(b - a), nearest[a:b]]
            gap = np.subtract(value, qr[a:b, None], out=value)  # |c_q - c_p| - r_p - r_q
            # candidates within the chunk's largest margin of overlap (a few per query), then
            # each candidate against its own margin
            widest = K_ROUNDING * EPS * (qn[a:b].max() + pn.max() + qr[a:b].max() + pr.max())
            cq, cp = np.nonzero(gap < widest)
            cq += a
            margin = K_ROUNDING * EPS * (qn[cq] + pn[cp] + qr[cq] + pr[cp])
            near_gap = gap[cq - a, cp]
            inside, doubt = near_gap <= -margin, np.abs(near_gap) < margin
            sure.append(cq[inside] * n + cp[inside])
            ambiguous.append(cq[doubt] * n + cp[doubt])
        sure = np.sort(np.concatenate(sure))
        return {"pairs": np.stack([sure // n, sure % n], axis=1).astype(float),
                "nearest": nearest.astype(float), "nearest_distance": distance,
                "sure_keys": sure, "ambiguous_keys": np.concatenate(ambiguous), **d}

    def _value(self, exact, query, prim):
        diff = exact["query_center"][query] - exact["prim_center"][prim]
        return np.sqrt(np.einsum("qk,qk->q", diff, diff)) - exact["prim_radius"][prim]

    def _near_margin(self, exact, query, prim):
        return K_ROUNDING * EPS * (np.linalg.norm(exact["query_center"][query], axis=1)
                                   + np.linalg.norm(exact["prim_center"][prim], axis=1)
                                   + exact["prim_radius"][prim])

    def measure(self, p, answered, exact) -> dict:
        n, m = int(p["n"]), int(p["m"])
        pairs = np.asarray(answered["pairs"], float).reshape(-1, 2)
        valid = np.all((pairs >= 0) & (pairs == np.round(pairs)), axis=1) \
            & (pairs[:, 0] < m) & (pairs[:, 1] < n)
        keys = pairs[valid, 0].astype(np.int64) * n + pairs[valid, 1].astype(np.int64)
        unique = np.unique(keys)
        allowed = np.union1d(exact["sure_keys"], exact["ambiguous_keys"])
        false_pos = int(np.sum(~np.isin(unique, allowed)) + (len(pairs) - len(unique)))
        false_neg = int(np.sum(~np.isin(exact["sure_keys"], unique)))
        index = np.asarray(answered["nearest"], float).reshape(-1)
        got = np.asarray(answered["nearest_distance"], float).reshape(-1)
        if index.shape != (m,) or got.shape != (m,):
            return {"false_negatives": false_neg, "false_positives": false_pos,
                    "nearest_err": float("inf"), "nearest_index_mismatch": m,
                    "ambiguous": len(exact["ambiguous_keys"])}
        star = exact["nearest"].astype(np.int64)
        ok = np.isfinite(index) & (index >= 0) & (index < n) & (index == np.round(index))
        j = np.where(ok, index, 0).astype(np.int64)
        queries = np.arange(m)
        excess = self._value(exact, queries, j) - exact["nearest_distance"]
        tie = excess <= self._near_margin(exact, queries, j) + \
            self._near_margin(exact, queries, star)
        return {"false_negatives": false_neg, "false_positives": false_pos,
                "nearest_err": float(np.max(np.abs(got - exact["nearest_distance"]))),
                "nearest_index_mismatch": int(np.sum(~ok | ((j != star) & ~tie))),
                "ambiguous": len(exact["ambiguous_keys"])}

    def bounds(self, p, settings) -> dict:
        exact = self.exact_cached(p)
        star = exact["nearest"].astype(np.int64)
        worst = float(np.max(self._near_margin(exact, np.arange(len(star)), star)))
        margin = (f"pairs within K eps (|c_q| + |c_p| + r_q + r_p) of touching, K = "
                  f"{K_ROUNDING}, are ambiguous and not counted")
        return {"false_negatives": (0, f"brute force finds every pair; {margin}"),
                "false_positives": (0, f"every answered pair must overlap; {margin}"),
                "nearest_err": (worst, f"both sides' rounding of |c_q - c_p| - r_p: K eps "
                                       f"(|c_q| + |c_p*| + r_p*), K = {K_ROUNDING}, largest "
                                       "over the batch"),
                "nearest_index_mismatch": (0, "the oracle's index, or one within the "
                                              "round-off margin of its distance (a tie)")}

    def motion_scale(self, p) -> float:
        """The tolerance column counts pairs: the batch's expected overlapping pairs (M x
        pairs_per_query; no brute force for the definition)."""
        return float(max(1.0, p["m"] * p["pairs_per_query"]))

    def target_error(self, p) -> float:
        return 0.0  # no missed pair is good enough

    def error_floor(self, p) -> float:
        return 0.0


CASE = BvhSpheresCase()
