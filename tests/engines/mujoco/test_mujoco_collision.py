"""MuJoCo's box-pair queries (adapters/mujoco_engine/groups/collision_boxes.py): closed forms on
both formulations (nativeccd GJK/EPA, and nativeccd off: the dedicated box-box collider), the
sign conventions (normal from A towards B, both signs, swapped pairs), the chunked batch, the
touching fallback, and the engine facts of
docs/engine_notes.md#mujoco-box-pair-distance-routines (the collider's missed separated
pairs), #mujoco-nativeccd-near-touching-band and #mujoco-epa-wrong-penetration.
mujoco is imported on purpose: CI must have every engine (fail, never skip).
"""
import mujoco  # fail, never skip, without the engine
import numpy as np
import pytest

from refsim.registry import get_engine
from refsim.scene import Scene
from refsim.scene.queries import BoxPairs
from refsim_adapters.mujoco_engine.groups.collision_boxes import CHUNK, MujocoBoxPairsSim

ENGINE = get_engine("mujoco")
EPS = np.finfo(float).eps
FORMULATIONS = ("", "nativeccd_off")
I3 = np.eye(3)


def rot(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def pairs(rows):
    """BoxPairs from rows (a_center, a_half, a_rotation, b_center, b_half, b_rotation)."""
    return BoxPairs(*[np.array([r[k] for r in rows], float) for k in range(6)])


def answer(part, formulation=""):
    sim = ENGINE.build(Scene(parts=(part,), dim=3), 1.0, "query", formulation)
    sim.step(1)
    obs = sim.observe()
    return {k: obs[f"query.{k}"] for k in ("overlap", "distance", "normal")}, sim


SQ = np.sqrt(0.5)
# (name, row, exact distance, exact normal): slide 001's separating axes; MODELS.md section 7
CLOSED = [
    ("faces apart", ([0, 0, 0], [1, 1, 1], I3, [3, 0, 0], [.5, .5, .5], I3), 1.5, [1, 0, 0]),
    ("faces overlap", ([0, 0, 0], [1, 1, 1], I3, [1.2, 0, 0], [.5, .5, .5], I3), -0.3,
     [1, 0, 0]),
    ("overlap towards -x", ([0, 0, 0], [1, 1, 1], I3, [-1.2, .1, 0], [.5, .5, .5], I3), -0.3,
     [-1, 0, 0]),
    ("45 deg apart", ([0, 0, 0], [.5] * 3, I3, [2, 0, 0], [.5] * 3, rot([0, 0, 1], np.pi / 4)),
     1.5 - SQ, [1, 0, 0]),
    ("45 deg overlap", ([0, 0, 0], [.5] * 3, I3, [1, 0, 0], [.5] * 3, rot([0, 0, 1], np.pi / 4)),
     0.5 - SQ, [1, 0, 0]),
    ("corners apart", ([0, 0, 0], [1, 1, 1], I3, [3, 3, 3], [.5] * 3, I3), 1.5 * np.sqrt(3),
     np.ones(3) / np.sqrt(3)),
    ("edges apart", ([0, 0, 0], [1, 1, 1], I3, [3, 3, 0], [.5] * 3, I3), 1.5 * np.sqrt(2),
     [SQ, SQ, 0]),
]
COLLIDER_MISSES = {"corners apart", "edges apart"}  # no face overlap: mjc_BoxBox finds nothing


def _bound(row):
    """Round-off of the inputs and of the few-term support sums: 8 eps of the geometry's size
    (centre distance plus both half diagonals); the rotations' sin/cos(pi/4) are rounded too."""
    ca, ha, _, cb, hb, _ = (np.asarray(x, float) for x in row)
    return 8 * EPS * (np.linalg.norm(cb - ca) + np.linalg.norm(ha) + np.linalg.norm(hb))


@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_closed_forms(formulation):
    """Distance exact to round-off and the unit normal from A towards B on both signs; with
    nativeccd off, the corner and edge gaps are missed (distmax answered, normal NaN)."""
    got, sim = answer(pairs([c[1] for c in CLOSED]), formulation)
    for i, (name, row, dist, normal) in enumerate(CLOSED):
        if formulation == "nativeccd_off" and name in COLLIDER_MISSES:
            assert got["distance"][i] == sim.distmax, name
            assert np.isnan(got["normal"][i]).all(), name
            continue
        assert abs(got["distance"][i] - dist) <= _bound(row), (name, got["distance"][i], dist)
        # normal: witness points' round-off over the distance (>= 0.2 m here), unit length
        assert np.abs(got["normal"][i] - normal).max() <= 1e-14, (name, got["normal"][i])
        assert got["overlap"][i] == float(dist < 0), name


@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_swapping_a_and_b_flips_the_normal(formulation):
    """A catch for a sign taken from the wrong witness point: B->A gives -normal, same
    distance (same routine on swapped geoms: equal to round-off, 8 eps as above)."""
    rows = [c[1] for c in CLOSED if c[0] not in COLLIDER_MISSES]
    swapped = [(r[3], r[4], r[5], r[0], r[1], r[2]) for r in rows]
    ab, _ = answer(pairs(rows), formulation)
    ba, _ = answer(pairs(swapped), formulation)
    assert np.abs(ab["distance"] - ba["distance"]).max() <= max(_bound(r) for r in rows)
    assert np.abs(ab["normal"] + ba["normal"]).max() <= 1e-14


def _random(n, seed, spread=1.5):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(2 * n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    mats = np.zeros((2 * n, 9))
    for i in range(2 * n):
        mujoco.mju_quat2Mat(mats[i], q[i])
    mats = mats.reshape(2 * n, 3, 3)
    ca = rng.uniform(-10, 10, (n, 3))
    return BoxPairs(ca, rng.uniform(.1, 1, (n, 3)), mats[:n], ca + rng.normal(size=(n, 3)) *
                    spread, rng.uniform(.1, 1, (n, 3)), mats[n:])


def test_chunks_equal_pairs_answered_alone():
    """More pairs than one chunk model holds: each answer equals the pair answered alone, bit
    for bit (same call on the same inputs; catches a chunk offset or a stale row)."""
    part = _random(CHUNK + 37, seed=3)
    got, _ = answer(part)
    for i in (0, CHUNK - 1, CHUNK, CHUNK + 36):
        one = BoxPairs(*(getattr(part, f)[i:i + 1] for f in (
            "a_center", "a_half", "a_rotation", "b_center", "b_half", "b_rotation")))
        alone = MujocoBoxPairsSim(one, 1.0, "").answer()
        assert alone["distance"][0] == got["distance"][i]
        assert np.array_equal(alone["normal"][0], got["normal"][i])


def test_separated_normal_closes_the_gap():
    """nativeccd on random separated pairs: moving B by -(d - g) n leaves a gap g = 1e-3 m
    (the distance and the normal agree; a wrong normal or sign opens or keeps the gap). The
    bound: the shift's and the answers' round-off, 64 eps of the 10 m coordinates."""
    part = _random(400, seed=11)
    got, _ = answer(part)
    apart = got["distance"] > 0.01
    shift = (got["distance"][apart] - 1e-3)[:, None] * got["normal"][apart]
    moved = BoxPairs(part.a_center[apart], part.a_half[apart], part.a_rotation[apart],
                     part.b_center[apart] - shift, part.b_half[apart], part.b_rotation[apart])
    again, _ = answer(moved)
    assert apart.sum() > 200
    assert np.abs(again["distance"] - 1e-3).max() <= 64 * EPS * 20


def test_touching_pair_takes_the_contact_normal():
    """from = to at distance 0: the normal comes from mj_collision's contact frame (A->B)."""
    rows = [([0, 0, 0], [1, 1, 1], I3, [1.5, .1, 0], [.5] * 3, I3),
            ([1.5, .1, 0], [.5] * 3, I3, [0, 0, 0], [1, 1, 1], I3)]
    for formulation in FORMULATIONS:
        got, _ = answer(pairs(rows), formulation)
        assert np.array_equal(got["distance"], [0.0, 0.0])
        assert np.allclose(got["normal"], [[1, 0, 0], [-1, 0, 0]], rtol=0, atol=1e-15)


def test_near_touching_band_of_nativeccd():
    """Engine fact: separated pairs 1e-8 m apart are answered 0 or negative by some random
    poses under the default ccd_tolerance 1e-6 (never at 1e-6 m apart); ccd_tolerance 1e-12
    removes it. Gaps set by shifting B along MuJoCo's own normal (checked above)."""
    part = _random(400, seed=5, spread=2.0)
    got, _ = answer(part)
    apart = got["distance"] > 0.01

    def with_gap(gap, tol):
        shift = (got["distance"][apart] - gap)[:, None] * got["normal"][apart]
        sim = MujocoBoxPairsSim(BoxPairs(
            part.a_center[apart], part.a_half[apart], part.a_rotation[apart],
            part.b_center[apart] - shift, part.b_half[apart], part.b_rotation[apart]), 1.0, "")
        sim.model.opt.ccd_tolerance = tol
        return sim.answer()["distance"]

    assert np.sum(with_gap(1e-8, 1e-6) <= 0) >= 5
    assert np.min(with_gap(1e-6, 1e-6)) > 0
    assert np.min(with_gap(1e-8, 1e-12)) > 0


# A pair (seeded batch, seed 7) where nativeccd's EPA returns a wrong penetration; values exact
WRONG_EPA = np.array([
    0.22841463241892512, -5.481618171153626, -1.169790418496774, 0.803498412035985,
    0.28064680781731993, 0.21496146742798244, -0.8600619756217094, -0.3103331385689949,
    -0.40495276415354653, -0.21738721369139044, -0.4951622872095409, 0.8411641389460852,
    -0.46155844420092096, 0.811484844240071, 0.3584077986811849, 1.258798554050662,
    -5.520660998517614, -0.16104637227589924, 0.6694221709895406, 0.5855183803138003,
    0.6415387527096609, -0.1729821883618603, 0.9508849658338172, -0.2567001056890365,
    -0.04265246079383744, -0.2676167477955116, -0.962580928487358, -0.9840009807402492,
    -0.15556046429145887, 0.08685051440062774])


def test_epa_wrong_penetration_fact():
    """Engine fact: on this pair EPA answers depth 0.218 m along a normal on which the boxes
    overlap by 0.351 m (moving B by the answer leaves them overlapping: no oracle needed; the
    exact depth is 0.2637 m by SAT); nativeccd off (the box-box collider) is right to 1e-12."""
    v = WRONG_EPA
    ca, ha, ra, cb, hb, rb = v[0:3], v[3:6], v[6:15].reshape(3, 3), v[15:18], v[18:21], \
        v[21:30].reshape(3, 3)
    part = pairs([(ca, ha, ra, cb, hb, rb)])

    def overlap_along(n):
        return (np.abs(ra.T @ n) @ ha + np.abs(rb.T @ n) @ hb - abs(n @ (cb - ca)))

    got, _ = answer(part)
    depth, normal = -got["distance"][0], got["normal"][0]
    assert overlap_along(normal) - depth > 0.1
    off, _ = answer(part, "nativeccd_off")
    assert abs(-off["distance"][0] - 0.2637328839223245) <= 1e-12  # SAT oracle's value
    assert abs(overlap_along(off["normal"][0]) + off["distance"][0]) <= 1e-12


def test_settings_declare_the_routine_and_tolerances():
    part = pairs([CLOSED[0][1]])
    for formulation, native in (("", "enabled"), ("nativeccd_off", "disabled")):
        s = ENGINE.build(Scene(parts=(part,), dim=3), 1.0, "query", formulation).settings()
        assert s["nativeccd"] == native and s["precision"] == "float64"
        assert s["ccd_tolerance"] == 1e-6 and s["ccd_iterations"] == 35
        assert s["distance_tolerance"] == (2e-6 if native == "enabled" else 0.0)
        assert "mjc_BoxBox" in s["routine"] if formulation else "mjc_ccd" in s["routine"]
        assert s["integrator"] == {"name": "query", "order": 0}
    assert ENGINE.formulations(Scene(parts=(part,), dim=3)) == FORMULATIONS


def test_against_refsims_sat():
    """A seeded random batch against refsim's SAT and feature-pair distance (refsim.models.
    collision.sat.box_pairs, exact to round-off; tests/models/test_collision_sat.py).
    nativeccd: every distance within both sides' round-off, 16 eps S (1 + lever) per pair
    twice (S the pair's largest coordinate, lever its bounding diagonal over the shortest box
    edge: the oriented_boxes case's bound), normals to 1e-9 where |d| > 1e-3 m (round-off of
    the witness points, eps S / |d| < 5e-12, times 200). nativeccd off: same overlap verdicts
    on pairs 1e-6 m from touching, depths at most 5 % too deep (the collider prefers a face
    axis to an edge axis within 5 % of the depth), and some separated pairs missed (distmax)."""
    from refsim.models.collision.sat import box_pairs
    part = _random(300, seed=21)
    fields = ("a_center", "a_half", "a_rotation", "b_center", "b_half", "b_rotation")
    ref = box_pairs(*(getattr(part, f) for f in fields))
    scale = np.maximum(np.abs(part.a_center).max(1), np.abs(part.b_center).max(1)) + 2.0
    diag = np.linalg.norm(part.a_center - part.b_center, axis=1) + 2 * np.sqrt(3)
    lever = diag / (2 * np.minimum(part.a_half.min(1), part.b_half.min(1)))
    bound = 2 * 16 * EPS * scale * (1 + lever)
    got, sim = answer(part)
    assert np.all(np.abs(got["distance"] - ref["distance"]) <= bound)
    clear = np.abs(ref["distance"]) > 1e-3
    assert np.abs(got["normal"][clear] - ref["normal"][clear]).max() <= 1e-9
    off, sim = answer(part, "nativeccd_off")
    sure = np.abs(ref["distance"]) > 1e-6
    assert np.array_equal(off["overlap"][sure], ref["overlap"][sure])
    inside = ref["distance"] < -1e-6
    assert np.all(off["distance"][inside] <= ref["distance"][inside] + bound[inside])
    assert np.all(off["distance"][inside] >= 1.05 * ref["distance"][inside])
    assert np.sum(off["distance"] == sim.distmax) > 0
