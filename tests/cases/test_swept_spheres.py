"""swept_spheres: the batch's answers known by construction, refsim's closed form within each
query's own bound, and the defects the verdict must catch (float32, an end-of-step detection,
the contact radius dropped)."""
from __future__ import annotations

import numpy as np
import pytest

from refsim.models.collision.swept import time_of_impact
from refsim.registry import get_case

CASE = get_case("swept_spheres")


def _answer(p, fn=time_of_impact):
    part = CASE.scene(p).parts[0]
    return {"toi": fn(part.c1, part.v1, part.r1, part.c2, part.v2, part.r2, part.t_max)}


def _verdict(p, answered, settings=None):
    exact = CASE.exact_cached(p)
    measured = CASE.measure(p, answered, exact)
    bounds = CASE.bounds(p, settings or {})
    return measured, {k: measured[k] <= b for k, (b, _) in bounds.items()}


@pytest.mark.parametrize("variant", ["default", "far"])
def test_constructed_answers_hold_exactly_in_the_closed_form(variant):
    """Each hit's |p0 + v t*| = R to round-off, its approach along -n; misses never reach R."""
    p = CASE.variant_params(variant)
    d = CASE._draw(p)
    p0, v = d["c2"] - d["c1"], d["v2"] - d["v1"]
    reach = d["r1"] + d["r2"]
    hit = np.isfinite(d["t_star"]) & (d["t_star"] > 0)
    gap = np.linalg.norm(p0[hit] + v[hit] * d["t_star"][hit, None], axis=1) - reach[hit]
    scale = np.linalg.norm(d["c1"][hit], axis=1) + np.linalg.norm(d["c2"][hit], axis=1) + 1
    assert np.all(np.abs(gap) <= 64 * np.finfo(float).eps * scale)  # input rounding only
    assert np.all(np.einsum("nk,nk->n", d["normal"], d["v"])[hit] < 0)
    counts = {k: int(np.sum(d["kind"] == k)) for k in set(d["kind"])}
    assert sum(counts.values()) == p["n"] and counts["flyby"] == 0.2 * p["n"]


@pytest.mark.parametrize("variant", ["default", "far"])
def test_closed_form_is_within_every_bound(variant):
    p = CASE.variant_params(variant)
    measured, ok = _verdict(p, _answer(p))
    assert all(ok.values()), measured
    assert measured["false_negatives"] == measured["false_positives"] == 0


def _float32(c1, v1, r1, c2, v2, r2, t_max):
    args = [np.asarray(a, np.float32) for a in (c1, v1, r1, c2, v2, r2)]
    return time_of_impact(*args, np.float32(t_max)).astype(float)


def _end_of_step(*args):
    return np.ceil(time_of_impact(*args) / 0.01) * 0.01


def _no_radius(c1, v1, r1, c2, v2, r2, t_max):
    return time_of_impact(c1, v1, r1 * 1e-9, c2, v2, r2 * 1e-9, t_max)


@pytest.mark.parametrize("defect,column", [(_float32, "toi_err"), (_end_of_step, "toi_err"),
                                           (_no_radius, "false_negatives")])
def test_planted_defects_are_caught(defect, column):
    """Measured once: float32 toi_err_ratio ~3e7, end of a 0.01 step ~1e12, R dropped 650
    false negatives."""
    p = CASE.variant_params("default")
    measured, ok = _verdict(p, _answer(p, defect))
    assert not ok[column], measured


def test_a_declared_tolerance_widens_the_bounds_by_exactly_itself():
    p = CASE.variant_params("default")
    plain, wide = CASE.bounds(p, {}), CASE.bounds(p, {"toi_tolerance": 1e-6})
    assert wide["toi_err"][0] == pytest.approx(plain["toi_err"][0] + 1e-6, rel=1e-12)
