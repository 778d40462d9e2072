"""Time of impact of swept spheres against the closed form (issue 28, case 4; slide 001's
"discrete vs continuous" detection).

A seeded batch of n pairs of spheres moving at constant velocity over the window [0, t_max].
The answers are known by construction, not by the algorithm under test: for a hit, a contact
time t*, a contact normal n and a relative velocity v approaching along n (v.n <= -cos(80 deg)
|v|: no grazing) are drawn first, and the relative position at t = 0 is p0 = R n - v t*
(R = r1 + r2), so |p0 + v t*| = R. The batch mixes (shares of n):
- hits, t* in [0.05, 0.95] t_max (55 %);
- imminent hits, t* log-uniform in [1e-6, 1e-3] t_max (5 %): |p0| within a hair of R;
- fly-bys, closest approach d in [1.05, 3] R (20 %): no contact, NaN;
- receding pairs, |p0| in [1.5, 3] R and v.p0 > 0 (5 %): NaN;
- late hits, t* in [1.05, 2] t_max, beyond the window (10 %): NaN;
- overlapping at t = 0, |p0| in [0.2, 0.8] R (5 %): 0.
Positions c1 uniform in [-L, L]^3, c2 = c1 + p0; velocities v1 uniform in [-V, V]^3, v2 = v1 + v;
speeds |v| log-uniform in [0.1, 10] R / t_max x `speed`.

Measures: `toi_err` (s) max |t - t*| over the queries both call hits (the tolerance column);
`toi_err_ratio` max over them of |t - t*| / B_i, each query's own bound; `false_negatives`
(an exact hit answered NaN) and `false_positives` (a miss answered with a time); the margins
above (5 % of the window, 5 % of R) keep every query's class unambiguous at round-off.

Bound, per query: the inputs reach the engine rounded (c2 = c1 + p0, v2 = v1 + v, R = r1 + r2,
and the engine's own p = c2 - c1, v = v2 - v1), each an absolute error of a few eps of the
largest term. The contact condition |p + v t| = R moves by n.(dp + t dv) - dR, so the time
moves by dt = (n.(dp + t dv) - dR) / (-n.v): B_i = K eps (|c1| + |c2| + t* (|v1| + |v2|) + R)
/ |n.v|, with K = 16 (two roundings of each input, the subtraction, the three-term dot
products and the root: each an eps of a term of the sum, with margin 2); plus the engine's
declared time-of-impact tolerance (settings "toi_tolerance", 0 where none). What it catches
(planted once, `refsim run --case swept_spheres` with the model patched): float32 arithmetic
(toi_err_ratio 1e7), a detection at the end of a discrete step of 0.01 t_max (1e9-1e12), a
contact at the centres (R dropped: 650 false negatives). What it cannot tell apart, rightly:
the textbook root (-b - sqrt(b^2 - a c)) / a, whose cancellation on the imminent hits is an
absolute error of about eps R / |v|, below the inputs' own rounding (measured: within the bound
like the stable form).
"""
from __future__ import annotations

import numpy as np

from refsim.case import EPS, Param
from refsim.query import QueryCase
from refsim.scene import Scene
from refsim.scene.queries import SweptSpheres

SHARES = {"hit": 0.55, "imminent": 0.05, "flyby": 0.20, "receding": 0.05, "late": 0.10, "overlap": 0.05}
GRAZING_DEG = 80.0  # the largest angle between -v and n for a hit
K_ROUNDING = 16


def _unit(rng, n):
    u = rng.normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=1)[:, None]


def _perpendicular(rng, n_vec):
    """A unit vector perpendicular to each row of n_vec."""
    m = np.cross(n_vec, _unit(rng, len(n_vec)))
    return m / np.linalg.norm(m, axis=1)[:, None]


class SweptSpheresCase(QueryCase):
    name = "swept_spheres"
    description = ("time of impact of swept sphere pairs against answers known by "
                   "construction (hits, fly-bys, receding, late, overlapping)")
    tags = ("collision", "queries", "continuous", "exact")
    answers = ("toi",)
    measures = {"toi_err": ("s", "max |t - t*| over the queries both call hits"),
                "toi_err_ratio": ("of B_i", "max |t - t*| / B_i (each query's bound)"),
                "false_negatives": ("queries", "exact hits answered NaN"),
                "false_positives": ("queries", "misses answered with a time")}
    params = {
        "n": Param(1000, 20, 1e7, "queries in the batch"),
        "seed": Param(1, 0, 2 ** 31, "random seed"),
        "extent": Param(10.0, 0.0, 1e6, "half side L of the box holding c1 (m)"),
        "speed": Param(1.0, 1e-3, 1e6, "scale of the relative speeds", low_inclusive=False),
        "v_frame": Param(1.0, 0.0, 1e6, "half side V of the box of v1 (m/s)"),
        "t_max": Param(1.0, 1e-6, 1e6, "window (s)", low_inclusive=False),
    }
    variants = {"default": {}, "far": {"extent": 1e4}, "large": {"n": 1e5}}
    default_variants = quick_variants = ("default", "far")

    # -- the batch ------------------------------------------------------------------------------
    def batch(self, p) -> int:
        return int(p["n"])

    def _draw(self, p) -> dict:
        """Every array of the batch and its exact answer (drawn once per p, seeded)."""
        rng = np.random.default_rng(int(p["seed"]))
        n, t_max = int(p["n"]), p["t_max"]
        counts = {k: int(round(s * n)) for k, s in SHARES.items()}
        counts["hit"] += n - sum(counts.values())
        kind = np.repeat(list(SHARES), [counts[k] for k in SHARES])
        r1, r2 = rng.uniform(0.05, 0.5, n), rng.uniform(0.05, 0.5, n)
        reach = r1 + r2
        normal = _unit(rng, n)
        side = _perpendicular(rng, normal)
        speed = reach / t_max * p["speed"] * np.exp(rng.uniform(np.log(0.1), np.log(10), n))
        theta = np.radians(rng.uniform(0.0, GRAZING_DEG, n))
        v = speed[:, None] * (-np.cos(theta)[:, None] * normal + np.sin(theta)[:, None] * side)
        t_star = np.full(n, np.nan)
        hit, late, soon = kind == "hit", kind == "late", kind == "imminent"
        t_star[hit] = rng.uniform(0.05, 0.95, hit.sum()) * t_max
        t_star[soon] = np.exp(rng.uniform(np.log(1e-6), np.log(1e-3), soon.sum())) * t_max
        t_hit = np.where(late, rng.uniform(1.05, 2.0, n) * t_max, t_star)
        p0 = reach[:, None] * normal - v * np.nan_to_num(t_hit)[:, None]
        # fly-bys: v along -normal's perpendicular, closest approach d > R at t_c in (0, 1)
        fly = kind == "flyby"
        d = rng.uniform(1.05, 3.0, n) * reach
        t_c = rng.uniform(0.0, 1.0, n) * t_max
        v_fly = speed[:, None] * side
        p0[fly] = (d[:, None] * normal - v_fly * t_c[:, None])[fly]
        v[fly] = v_fly[fly]
        recede, overlap = kind == "receding", kind == "overlap"
        p0[recede] = (rng.uniform(1.5, 3.0, n)[:, None] * reach[:, None] * normal)[recede]
        v[recede] = (speed[:, None] * normal)[recede]
        p0[overlap] = (rng.uniform(0.2, 0.8, n)[:, None] * reach[:, None] * normal)[overlap]
        t_star[overlap] = 0.0
        c1 = rng.uniform(-p["extent"], p["extent"], (n, 3))
        v1 = rng.uniform(-p["v_frame"], p["v_frame"], (n, 3))
        return {"c1": c1, "v1": v1, "r1": r1, "c2": c1 + p0, "v2": v1 + v, "r2": r2,
                "t_star": t_star, "normal": normal, "v": v, "kind": kind}

    def scene(self, p):
        d = self._draw(p)
        part = SweptSpheres(d["c1"], d["v1"], d["r1"], d["c2"], d["v2"], d["r2"], p["t_max"])
        return Scene(parts=(part,), dim=3)

    # -- answers --------------------------------------------------------------------------------
    def exact(self, p) -> dict:
        d = self._draw(p)
        scale = (np.linalg.norm(d["c1"], axis=1) + np.linalg.norm(d["c2"], axis=1)
                 + np.nan_to_num(d["t_star"]) * (np.linalg.norm(d["v1"], axis=1)
                                                 + np.linalg.norm(d["v2"], axis=1))
                 + d["r1"] + d["r2"])
        approach = np.abs(np.einsum("nk,nk->n", d["normal"], d["v"]))
        with np.errstate(divide="ignore"):
            bound = K_ROUNDING * EPS * scale / approach
        return {"toi": d["t_star"], "bound": bound}

    def measure(self, p, answered, exact) -> dict:
        t, t_star = np.asarray(answered["toi"], float), exact["toi"]
        both = np.isfinite(t) & np.isfinite(t_star)
        err = np.abs(t - t_star)[both]
        ratio = err / exact["bound"][both] if both.any() else np.zeros(0)
        return {"toi_err": float(err.max()) if both.any() else 0.0,
                "toi_err_ratio": float(np.max(ratio, initial=0.0)),
                "false_negatives": int(np.sum(np.isfinite(t_star) & ~np.isfinite(t))),
                "false_positives": int(np.sum(~np.isfinite(t_star) & np.isfinite(t)))}

    def bounds(self, p, settings) -> dict:
        extra = float((settings or {}).get("toi_tolerance", 0.0))
        exact = self.exact_cached(p)
        finite = np.isfinite(exact["toi"])
        worst = float(np.max(exact["bound"][finite]))
        ratio_bound = 1.0 + extra / float(np.min(exact["bound"][finite]))
        why = (f"inputs rounded on the way in and in the engine: dt = K eps (|c1| + |c2| + "
               f"t (|v1| + |v2|) + R) / |n.v|, K = {K_ROUNDING}, largest over the batch"
               + (f"; plus the engine's declared tolerance {extra:g} s" if extra else ""))
        return {"toi_err": (worst + extra, why),
                "toi_err_ratio": (ratio_bound, "each query within its own bound B_i" + (
                    " plus the engine's tolerance" if extra else "")),
                "false_negatives": (0, "every hit is 5 % of the window inside it"),
                "false_positives": (0, "every miss is 5 % of R or of the window clear")}

    def motion_scale(self, p) -> float:
        return p["t_max"]

    def target_error(self, p) -> float:
        return 1e-9 * p["t_max"]

    def error_floor(self, p) -> float:
        return 0.0


CASE = SweptSpheresCase()
