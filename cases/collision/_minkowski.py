"""The brute-force oracle of the convex pair cases (convex_polygons, oriented_boxes): the
Minkowski difference D = B - A = hull{b_j - a_i} of every pair, by Qhull
(scipy.spatial.ConvexHull), a different algorithm from the separating axes under test.

- A and B overlap iff the origin is in D (every facet's plane value n.0 + offset <= 0).
- Apart: the distance is that of the origin to D: the least distance to D's facets (segments in
  2D, triangles in 3D) facing the origin (offset > 0), each by the closest point of the simplex
  (the plane's foot if inside the triangle, else the nearest edge point); the normal is c / |c|
  with c that closest point (c = b* - a*: from A to B).
- Overlapping: the depth is the least distance from the origin to a facet's plane, -max offset,
  and the normal minus that facet's outward normal (D's outward normals point from B to A:
  moving B by depth x normal moves D by as much, taking its nearest facet past the origin).
  `normal_gap` is the depth difference to the nearest facet of another plane: where it is
  within a case's margin the normal is ambiguous at round-off.

The hull is the only loop over pairs (one Qhull call each: 0.13 s for 10^3 polygon pairs, 0.25 s
for 10^3 box pairs, measured); the simplices of all pairs are then measured at once, in chunks.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull

from refsim.case import EPS, Param
from refsim.query import QueryCase
from refsim.scene import Scene

CHUNK = 200_000  # facets measured at once (memory: a few (CHUNK, 3, 3) arrays)
SAME_PLANE = 1e-12  # |n - n'| below this: one plane (Qhull gives a merged facet's triangles
#                     bit-identical equations)


def _hulls(a_pts, a_count, b_pts, b_count):
    """Every pair's hull: (equations (F, d + 1), simplices' points (F, d, d), pair of each)."""
    eqs, simp, owner = [], [], []
    n, ka, dim = a_pts.shape
    every = (b_pts[:, :, None, :] - a_pts[:, None, :, :]).reshape(n, -1, dim)
    real = ((np.arange(b_pts.shape[1])[None, :, None] < b_count[:, None, None]) &
            (np.arange(ka)[None, None, :] < a_count[:, None, None])).reshape(n, -1)
    full = real.all(axis=1)
    for i in range(n):
        pts = every[i] if full[i] else every[i][real[i]]
        hull = ConvexHull(pts)
        eqs.append(hull.equations)
        simp.append(pts[hull.simplices])
        owner.append(np.full(len(hull.equations), i))
    return np.concatenate(eqs), np.concatenate(simp), np.concatenate(owner)


def _closest_on_segment(p0, p1):
    """The closest point to the origin on segments p0 -> p1 (m, d)."""
    e = p1 - p0
    t = np.clip(-np.einsum("md,md->m", p0, e) / np.einsum("md,md->m", e, e), 0.0, 1.0)
    return p0 + t[:, None] * e


def _closest_on_simplex(s):
    """The closest point to the origin on each simplex (m, d, d): a segment in 2D; in 3D a
    triangle: the plane's foot where its barycentric coordinates are >= 0, else the nearest of
    the three edges' closest points."""
    if s.shape[1] == 2:
        return _closest_on_segment(s[:, 0], s[:, 1])
    p0, p1, p2 = s[:, 0], s[:, 1], s[:, 2]
    cands = [_closest_on_segment(p0, p1), _closest_on_segment(p1, p2),
             _closest_on_segment(p2, p0)]
    nrm = np.cross(p1 - p0, p2 - p0)
    nn = np.einsum("md,md->m", nrm, nrm)
    foot = nrm * (np.einsum("md,md->m", p0, nrm) / nn)[:, None]
    bary = [np.einsum("md,md->m", np.cross(q1 - foot, q2 - foot), nrm)
            for q1, q2 in ((p1, p2), (p2, p0), (p0, p1))]
    inside = (bary[0] >= 0) & (bary[1] >= 0) & (bary[2] >= 0)
    cands.append(np.where(inside[:, None], foot, np.inf))
    stack = np.stack(cands, axis=1)
    dist = np.linalg.norm(stack, axis=-1)
    return stack[np.arange(len(s)), np.argmin(dist, axis=1)]


def oracle(a_pts, a_count, b_pts, b_count) -> dict:
    """Exact answers of the pairs (A's points (n, ka, d) of which the first a_count[i] are
    real, B's likewise): {"overlap" (n,) 1/0, "distance" (n,), "normal" (n, d), "normal_gap" (n,)
    (overlapping: depth margin to another plane's facet; inf apart)}."""
    a_pts, b_pts = np.asarray(a_pts, float), np.asarray(b_pts, float)
    n, dim = len(a_pts), a_pts.shape[2]
    eq, simp, owner = _hulls(a_pts, np.asarray(a_count), b_pts, np.asarray(b_count))
    offset, normals = eq[:, -1], eq[:, :dim]
    best = np.full(n, -np.inf)
    np.maximum.at(best, owner, offset)
    # the facet attaining each pair's largest offset (the last of equal ones)
    top = np.zeros(n, int)
    top[owner[offset == best[owner]]] = np.nonzero(offset == best[owner])[0]
    overlap = best <= 0
    normal = -normals[top]
    distance = best.copy()
    other = np.linalg.norm(normals - normals[top][owner], axis=1) > SAME_PLANE
    gap = np.full(n, np.inf)
    np.minimum.at(gap, owner[other], (best[owner] - offset)[other])
    gap[~overlap] = np.inf
    # apart: the distance from the origin to the facets it faces
    facing = np.nonzero((offset > 0) & ~overlap[owner])[0]
    dist_best = np.full(n, np.inf)
    point = np.zeros((n, dim))
    for start in range(0, len(facing), CHUNK):
        idx = facing[start:start + CHUNK]
        c = _closest_on_simplex(simp[idx])
        d = np.linalg.norm(c, axis=1)
        order = np.lexsort((d, owner[idx]))  # by pair, nearest first
        first = np.ones(len(order), bool)
        first[1:] = owner[idx][order][1:] != owner[idx][order][:-1]
        pick = order[first]
        who = owner[idx][pick]
        closer = d[pick] < dist_best[who]
        dist_best[who[closer]] = d[pick][closer]
        point[who[closer]] = c[pick][closer]
    apart = ~overlap
    distance[apart] = dist_best[apart]
    normal[apart] = point[apart] / dist_best[apart, None]
    return {"overlap": overlap.astype(float), "distance": distance, "normal": normal,
            "normal_gap": gap}


# -- what the two pair cases share: answers, measures, bounds ---------------------------------
FAR = 1e-3  # m: pairs this far from touching get a normal bound an engine's tolerance leaves
#             finite (the touching share's gaps stop here)
K_ROUNDING = 16  # round-off factor of the bounds (the cases' docstrings derive and measure it)


class ConvexPairCase(QueryCase):
    """A batch of convex pairs against the oracle. A subclass draws the batch (`draw(p, rng)` ->
    {"part": the query part, "a_pts", "a_count", "b_pts", "b_count": vertices for the oracle})
    and sizes the pairs idx (`sizes(drawn, idx)` -> {"scale" the largest coordinate of each
    pair, "lever" its longest lever over its shortest feature length, "feature" that length})."""

    answers = ("overlap", "distance", "normal")
    measures = {"distance_err": ("m", "max |d - d*| over every pair (signed distances)"),
                "normal_err_deg": ("deg", "max angle between normal and n* where n* is defined"),
                "normal_err_far_deg": ("deg", f"the same over the pairs {FAR:g} m or more from "
                                              "touching (and from a second plane's depth)"),
                "false_negatives": ("pairs", "overlapping by more than the margin, answered apart"),
                "false_positives": ("pairs", "apart by more than the margin, answered overlapping"),
                "ambiguous": ("pairs", "|d*| <= margin (overlap undefined) or an overlapping "
                                       "pair's two planes' depths within it (normal undefined)")}

    variants = {"default": {}, "large": {"n": 1e5}}
    default_variants = quick_variants = ("default",)

    @staticmethod
    def pair_params(region: str) -> dict:
        """The parameters both pair cases take; `region` names where A's centre lies."""
        return {
            "n": Param(1000, 20, 1e7, "pairs in the batch"),
            "seed": Param(1, 0, 2 ** 31, "random seed"),
            "extent": Param(10.0, 0.0, 1e6, f"half side L of the {region} holding A's centre "
                                            "(m)"),
            "checked": Param(5000, 20, 1e7, "pairs compared with the oracle (a seeded sample "
                                            "of the batch beyond it)"),
            "margin": Param(1e-9, 0.0, 1.0, "ambiguity margin (m): |d*| or an overlapping "
                                            "pair's two nearest planes' depths within it are "
                                            "not compared"),
        }

    def _draw(self, p) -> dict:
        """The batch of `draw(p, rng)`, drawn once per parameter set (seeded)."""
        cache = self.__dict__.setdefault("_drawn", {})
        key = tuple(sorted(p.items()))
        if key not in cache:
            cache.clear()
            cache[key] = self.draw(p, np.random.default_rng(int(p["seed"])))
        return cache[key]

    def batch(self, p) -> int:
        return int(p["n"])

    def scene(self, p):
        return Scene(parts=(self._draw(p)["part"],), dim=self.dim)

    def checked(self, p) -> np.ndarray:
        """The pairs compared with the oracle: all of a batch of up to p["checked"] pairs, else a
        seeded sample of that many (the oracle's ~0.1 ms a pair: 10^5 pairs would take ~10 s
        a row; the engine still answers the whole batch, which the throughput times)."""
        n, m = int(p["n"]), int(p["checked"])
        if n <= m:
            return np.arange(n)
        return np.sort(np.random.default_rng(int(p["seed"]) + 1).choice(n, m, replace=False))

    def exact(self, p) -> dict:
        d = self._draw(p)
        idx = self.checked(p)
        pick = {k: d[k][idx] for k in ("a_pts", "a_count", "b_pts", "b_count")}
        out = oracle(pick["a_pts"], pick["a_count"], pick["b_pts"], pick["b_count"])
        # per pair: the round-off of the distance, K eps S (1 + lever): every input rounded at
        # its magnitude S, and a normal built from a feature of length l turned by ~eps S / l
        # moving a point at lever x l by as much again
        size = self.sizes(d, idx)
        out["bound"] = K_ROUNDING * EPS * size["scale"] * (1.0 + size["lever"])
        out["feature"] = size["feature"]
        out["index"] = idx
        return out

    def _classes(self, p, exact):
        d, margin = exact["distance"], p["margin"]
        sure = np.abs(d) > margin
        normal_ok = sure & (exact["normal_gap"] > margin)
        far = (np.abs(d) >= FAR) & (exact["normal_gap"] >= FAR)
        return sure, normal_ok, far

    def _errors(self, p, answered, exact):
        """(distance errors, normal angles in degrees, overlap flags) of the compared pairs."""
        idx = exact["index"]
        d = np.asarray(answered["distance"], float)[idx]
        over = np.asarray(answered["overlap"], float)[idx] > 0.5
        nrm = np.asarray(answered["normal"], float).reshape(int(p["n"]), -1)[idx]
        err = np.abs(d - exact["distance"])
        ref = exact["normal"]
        cos = np.einsum("nd,nd->n", nrm, ref)
        sin = np.abs(nrm[:, 0] * ref[:, 1] - nrm[:, 1] * ref[:, 0]) if ref.shape[1] == 2 else \
            np.linalg.norm(np.cross(nrm, ref), axis=1)
        angle = np.degrees(np.arctan2(sin, cos))  # not arccos: its resolution near 0 is 2e-8 rad
        return err, np.where(np.isfinite(angle), angle, 180.0), over

    def answer_checks(self, p, answered, exact, settings) -> list[str]:
        """Each pair within its OWN bound: |d - d*| <= B_i + allowed_i and, where the normal
        is defined (the nearest plane ahead of the next by more than the engine's allowance),
        its angle <= turn_i (`_pair_bounds`). The batch maxima of `bounds` alone
        let a pair with a tight bound err up to the loosest pair's bound (an engine's declared
        depth tolerance on a deep pair made the normal bound 180 deg for the whole batch)."""
        err, angle, _ = self._errors(p, answered, exact)
        allowed, turn = self._pair_bounds(p, exact, settings)
        sure, normal_ok, _ = self._classes(p, exact)
        out = []
        bad = np.flatnonzero(~(np.where(np.isfinite(err), err, np.inf)
                               <= exact["bound"] + allowed))
        if len(bad):
            k = bad[np.argmax((err[bad] / (exact["bound"] + allowed)[bad]))]
            out.append(f"{len(bad)} pairs' distances beyond their own bounds (worst {err[k]:.3g} "
                       f"m against {exact['bound'][k] + allowed[k]:.3g} m)")
        # a normal is defined at the engine's tolerance only where the nearest plane beats the
        # next by more than that tolerance (else the other plane is as right)
        bad = np.flatnonzero(normal_ok & (exact["normal_gap"] > allowed) & ~(angle <= turn))
        if len(bad):
            k = bad[np.argmax(angle[bad] - turn[bad])]
            out.append(f"{len(bad)} pairs' normals beyond their own bounds (worst {angle[k]:.3g} "
                       f"deg against {turn[k]:.3g} deg)")
        return out

    def _pair_bounds(self, p, ex, settings):
        """Per compared pair: the engine's declared allowance on the distance (m) and the
        normal's bound (deg): the features' possible displacement (the allowance, or the
        engine's declared "feature_shift" where larger) over the length that turns the
        normal, as `bounds` uses them."""
        s = settings or {}
        tol = float(s.get("distance_tolerance", 0.0))
        rel = float(s.get("depth_relative_tolerance", 0.0))
        allowed = tol + rel * np.maximum(-ex["distance"], 0.0)
        reach = np.where(ex["overlap"] > 0.5, ex["feature"], np.minimum(np.abs(ex["distance"]),
                                                                          ex["feature"]))
        # "feature_shift" (m): how far an engine's own geometry moves the features the normal
        # joins (pybullet's margin shrinks a box corner by m sqrt 3 per box); else the
        # distance allowance is how far they may move
        shift = np.maximum(allowed, float(s.get("feature_shift", 0.0)))
        turn = np.degrees(np.minimum(np.pi, (ex["bound"] + shift) / reach))
        # an engine whose normal is an edge's, not the closest points' direction, this close to
        # touching (pymunk's point query below 1e-5 m) declares it: those normals are unbounded
        switch = float(s.get("gradient_edge_normal_below", 0.0))
        turn[(ex["overlap"] < 0.5) & (ex["distance"] <= switch)] = 180.0
        return allowed, turn

    def measure(self, p, answered, exact) -> dict:
        err, angle, over = self._errors(p, answered, exact)
        sure, normal_ok, far = self._classes(p, exact)
        truth = exact["overlap"] > 0.5
        return {"distance_err": float(np.max(np.where(np.isfinite(err), err, np.inf))),
                "normal_err_deg": float(np.max(angle[normal_ok], initial=0.0)),
                "normal_err_far_deg": float(np.max(angle[far], initial=0.0)),
                "false_negatives": int(np.sum(sure & truth & ~over)),
                "false_positives": int(np.sum(sure & ~truth & over)),
                "ambiguous": int(np.sum(~normal_ok))}

    def bounds(self, p, settings) -> dict:
        """Per pair the round-off B_i plus the engine's declared terms (settings, absent: 0):
        "distance_tolerance" (m, on every answer) and "depth_relative_tolerance" (of the depth,
        on overlapping pairs): E_i = B_i + tol + rel x depth_i; "gradient_edge_normal_below"
        (m): separated pairs closer than it get an edge's normal, unbounded (180 deg)."""
        tol = float((settings or {}).get("distance_tolerance", 0.0))
        rel = float((settings or {}).get("depth_relative_tolerance", 0.0))
        ex = self.exact_cached(p)
        sure, normal_ok, far = self._classes(p, ex)
        allowed, turn = self._pair_bounds(p, ex, settings)
        far_ok = 2 * float(np.max(allowed[far], initial=0.0)) < FAR
        far_bound = float(np.max(turn[far], initial=0.0)) if far_ok else 180.0
        near = int(np.sum(sure & (np.abs(ex["distance"]) <= allowed)))
        extra = "".join([f"; plus the engine's declared distance_tolerance {tol:g} m" if tol
                         else "", f"; plus its depth_relative_tolerance {rel:g} of each depth"
                         if rel else ""])
        return {
            "distance_err": (float(np.max(ex["bound"] + allowed)),
                             f"round-off K eps S (1 + lever), K = {K_ROUNDING}, S the pair's "
                             f"largest coordinate" + extra + ", largest over the batch"),
            "normal_err_deg": (float(np.max(turn[normal_ok], initial=0.0)),
                               "the distance bound over the length that turns the normal (the "
                               "shortest feature; apart, also |d*|), largest over the pairs"),
            "normal_err_far_deg": (far_bound, "as normal_err_deg over the far pairs (an engine "
                                   "within its tolerance picks the deepest plane there while "
                                   f"2 x its allowed error < {FAR:g} m; else 180)"),
            "false_negatives": (near, "pairs within the engine's allowed error of touching"
                                if tol or rel else "every compared pair is the margin from "
                                                   "touching"),
            "false_positives": (near, "as false negatives")}

    def error_floor(self, p) -> float:
        return 0.0
