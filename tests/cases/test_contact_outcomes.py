"""The contact cases' exact outcomes and initial states against the laws they rest on:
momentum conservation, Newton's restitution law, Coulomb's friction cone, the known head-on
numbers, and a box that starts legal (inside, no overlap, zero momentum, mean speed v)."""
import numpy as np
import pytest

from refsim_cases.spheres._impact import penetration
from refsim.registry import get_case

PAIRS, CRADLE, BOX = get_case("sphere_pairs"), get_case("newtons_cradle"), get_case("sphere_box")


def _momentum(m, v):
    return np.einsum("j,jk->k", m, v)


@pytest.mark.parametrize("variant,expected", [("head_on", [-1.0, 1.0]),
                                              ("head_on_e0.5", [-0.5, 0.5]),
                                              ("head_on_1to3", [-2.0, 0.0]),
                                              ("head_on_1to3_e0.5", [-1.25, -0.25])])
def test_head_on_outcomes_are_the_textbook_numbers(variant, expected):
    v_after, w_after = PAIRS.outcome(PAIRS.variant_params(variant))
    np.testing.assert_allclose(v_after[:, 0], expected, atol=1e-15)
    # exact zeros: head-on along x, every y, z and spin term is a product with an exact 0
    assert not np.any(v_after[:, 1:]) and not np.any(w_after)


@pytest.mark.parametrize("variant", list(PAIRS.variants))
def test_pair_outcome_conserves_momentum_and_obeys_restitution(variant):
    p = PAIRS.variant_params(variant)
    x0, v0, m, w0 = PAIRS.initial_state(p)
    v1, _ = PAIRS.outcome(p)
    np.testing.assert_allclose(_momentum(m, v1), _momentum(m, v0), atol=1e-14)
    x_contact = x0 + v0 * PAIRS.contact_time(p)
    normal = (x_contact[1] - x_contact[0]) / np.linalg.norm(x_contact[1] - x_contact[0])
    assert np.linalg.norm(x_contact[1] - x_contact[0]) == pytest.approx(2 * p["radius"])
    approach, separation = (v0[1] - v0[0]) @ normal, (v1[1] - v1[0]) @ normal
    assert separation == pytest.approx(-p["restitution"] * approach, abs=1e-14)


def test_oblique_friction_impulse_stays_in_the_coulomb_cone():
    p = PAIRS.variant_params("oblique_friction")
    x0, v0, m, w0 = PAIRS.initial_state(p)
    v1, w1 = PAIRS.outcome(p)
    impulse = m[1] * (v1[1] - v0[1])  # on sphere 2
    x_contact = x0 + v0 * PAIRS.contact_time(p)
    normal = (x_contact[1] - x_contact[0]) / (2 * p["radius"])
    normal_part = impulse @ normal
    tangential = np.linalg.norm(impulse - normal_part * normal)
    assert normal_part > 0 and 0 < tangential <= p["friction"] * normal_part * (1 + 1e-12)
    assert not np.allclose(w1, w0)  # friction changes the spins


def test_cradle_outcome_passes_the_striker_velocity_to_the_last_sphere():
    p = CRADLE.variant_params("cradle")
    x0, v0, m, w0 = CRADLE.initial_state(p)
    v1, _ = CRADLE.outcome(p)
    # exact: the outcome swaps copies of v0 (striker <-> last sphere), no arithmetic
    assert v1[-1, 0] == p["speed"] and not np.any(v1[:-1])
    # exact: one nonzero term m v plus exact zeros, whatever the order or fusing of the sum
    np.testing.assert_array_equal(_momentum(m, v1), _momentum(m, v0))
    assert np.sum(m * np.sum(v1 * v1, axis=1)) == np.sum(m * np.sum(v0 * v0, axis=1))


def test_cradle_spheres_at_rest_touch_exactly_and_the_striker_arrives_on_time():
    p = CRADLE.variant_params("cradle")
    x0, v0, _, _ = CRADLE.initial_state(p)
    assert np.all(np.diff(x0[1:, 0]) == 2 * p["radius"])  # r = 1/8: exact in binary
    gap = x0[1, 0] - x0[0, 0] - 2 * p["radius"]
    assert CRADLE.contact_time(p) == pytest.approx(gap / p["speed"], rel=1e-15)


@pytest.mark.parametrize("variant", list(BOX.variants))
def test_box_starts_inside_without_overlap_at_zero_momentum(variant):
    p = BOX.variant_params(variant)
    x, v, m, w = BOX.initial_state(p)
    side = BOX.box_side(p)
    assert len(x) == p["n_spheres"]
    assert penetration(x, p["radius"], side) == 0.0
    np.testing.assert_allclose(_momentum(m, v), 0.0, atol=1e-12 * len(x))
    assert np.mean(np.linalg.norm(v, axis=1)) == pytest.approx(p["speed"], rel=1e-12)
    assert side ** 3 * p["fraction"] == pytest.approx(
        p["n_spheres"] * 4 / 3 * np.pi * p["radius"] ** 3, rel=1e-12)


def test_penetration_reports_the_deepest_sphere_and_wall_overlap():
    x = np.array([[0.5, 0.5, 0.5], [0.68, 0.5, 0.5], [0.95, 0.5, 0.5]])
    assert penetration(x[:2], 0.1) == pytest.approx(0.02)
    assert penetration(x, 0.1, side=1.0) == pytest.approx(0.05)  # 0.95 + 0.1 - 1
    assert penetration(x[:1], 0.1, side=1.0) == 0.0


@pytest.mark.parametrize("case,variant", [(PAIRS, "head_on"), (CRADLE, "cradle")])
def test_single_impact_cases_reject_a_radius_of_half_a_metre_or_more(case, variant):
    with pytest.raises(ValueError, match="radius"):
        case.variant_params(variant, {"radius": 0.5})


def test_pair_rejects_an_impact_parameter_that_misses():
    with pytest.raises(ValueError, match="impact"):
        PAIRS.variant_params("oblique", {"impact": 0.2})
