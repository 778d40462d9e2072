"""tunnelling: refsim's discrete detection tunnels exactly where the theory says (plate side
"approach": ratio v dt / (w + 2r) above 1 + hair), continuous never and exact to round-off; the
"nearest" theory (pushed through past the mid-plane: above 1/2 + hair) against refsim with its
push-out switched to the face of least penetration; planted defects caught by the verdict."""
import numpy as np
import pytest

from refsim_cases.collision.tunnelling import CASE, RATIOS
from refsim.models.collision import plates as slab
from refsim.run.job import Job, run_job

THRESHOLD = CASE.variant_params("threshold")


def _row(formulation, variant="threshold", params=()):
    p = CASE.variant_params(variant, dict(params))
    return run_job(Job(CASE.name, variant, "refsim", formulation, "symplectic_euler",
                       CASE.reference_dt(p), params=tuple(params)), repeats=0)


def test_the_theory_of_the_listed_ratios():
    """approach: 1.002 the lowest of 5 tunnelling ratios, 1.0005 bounces (hair 1e-3);
    nearest: 0.502 the lowest of 9, 0.5005 bounces; continuous: none."""
    ratios = np.array(RATIOS)
    approach = CASE.theory_tunnels(THRESHOLD, "discrete", "approach")
    nearest = CASE.theory_tunnels(THRESHOLD, "discrete", "nearest")
    assert list(ratios[approach]) == [1.002, 1.5, 2.0, 3.0, 100.0]
    assert list(ratios[nearest]) == [0.502, 0.75, 0.999, 1.0005] + list(ratios[approach])
    assert not CASE.theory_tunnels(THRESHOLD, "continuous").any()
    assert CASE.theory_threshold(THRESHOLD, "discrete", "approach") == 1.001
    assert CASE.theory_threshold(THRESHOLD, "discrete", "nearest") == 0.501


def test_discrete_tunnels_exactly_at_the_theorys_threshold():
    row = _row("discrete")
    assert row["consistency"] == "consistent", row["consistency_reason"]
    assert (row["tunnelled"], row["threshold_ratio"], row["bounce_ratio"]) == (5, 1.002, 1.0005)
    # a bounced sphere leaves from the entry face at the end of its overlapping step (none of
    # its overlap kept), per sphere to round-off: x(T) and e v (T - dt) (|x| <= 12 m), a few
    # roundings each, over the smallest overlap v dt - delta = 0.03 m: 16 eps 12 / 0.03
    assert abs(row["bounce_depth_min"]) <= 16 * np.finfo(float).eps * 12 / 0.03
    assert abs(row["bounce_depth_max"]) <= 16 * np.finfo(float).eps * 12 / 0.03
    assert row["err_max"] <= row["tolerance"] < 0.01 + 1e-12  # e (dt - t_c) / T, T = 100 dt


def test_the_measured_threshold_on_a_fine_sweep_brackets_the_theory():
    """200 ratios log-spaced over [0.25, 3]: 0.95 % apart, the threshold 1.001 between."""
    row = _row("discrete", params=(("sweep", 200),))
    assert row["consistency"] == "consistent", row["consistency_reason"]
    assert row["bounce_ratio"] < 1.001 < row["threshold_ratio"]
    # adjacent ratios: one spacing 12^(1/199) apart (to the rounding of geomspace)
    assert row["threshold_ratio"] / row["bounce_ratio"] <= 12 ** (1 / 199) * (1 + 1e-12)


def test_continuous_never_tunnels_and_is_exact():
    row = _row("continuous")
    assert row["consistency"] == "consistent", row["consistency_reason"]
    assert row["tunnelled"] == 0 and np.isnan(row["threshold_ratio"])
    assert row["bounce_ratio"] == 100.0
    # the bound: 4 N eps (|x0| + v T) / (v T) of the slowest sphere (3 m travel)
    assert row["err_max"] <= row["tolerance"] < 5e-13


def test_e_half_moves_nothing_but_the_bounce():
    row = _row("discrete", "threshold_e0.5")
    assert row["consistency"] == "consistent", row["consistency_reason"]
    assert row["tunnelled"] == 5 and row["err_max"] <= row["tolerance"] < 0.005 + 1e-12


def test_nearest_face_push_out_tunnels_past_the_mid_plane(monkeypatch):
    """refsim with its discrete push-out switched to the face of least penetration: 9
    tunnel (from 0.502 up), the 'nearest' theory; declared as 'approach' it is caught."""
    from refsim_adapters.refsim_engine import contacts
    monkeypatch.setattr(contacts.ContactSim, "_start", lambda self: None)
    row = _row("discrete")
    assert (row["tunnelled"], row["threshold_ratio"], row["bounce_ratio"]) == (9, 0.502, 0.5005)
    assert row["consistency"] == "inconsistent" and "tunnelled 9" in row["consistency_reason"]
    settings = {"detection": "discrete", "plate_side": "nearest"}
    assert CASE.consistency_checks(THRESHOLD, row, settings) == []


def test_planted_continuous_time_of_impact_a_step_late_is_caught(monkeypatch):
    """The plate's contact applied at the end of the step (tau = h): the bounce is late by
    dt - t_c like a discrete one, err 0.00999 of the travel against a bound of 4e-13."""
    original = slab.plate_time_of_impact

    def late(x, v, radii, center, normal, thickness, half_size, h, axes=None):
        s, k, m, tau = original(x, v, radii, center, normal, thickness, half_size, h, axes)
        return s, k, m, np.full_like(tau, h)
    monkeypatch.setattr(slab, "plate_time_of_impact", late)
    row = _row("continuous")
    assert row["consistency"] == "inconsistent" and row["err_max"] > 1e10 * row["tolerance"]


@pytest.mark.parametrize("formulation", ["discrete", "continuous"])
def test_planted_plate_ten_percent_thicker_is_caught(monkeypatch, formulation):
    """w 1.1x: the extent w + 2r grows by 1.7 %, the approach threshold moves to 1.018: 1.002
    bounces, 4 tunnel against the theory's 5 (discrete). Continuous: the thicker plate already
    overlaps the spheres at t = 0 (0.88 mm deep), they bounce at once, 2 delta = 0.24 mm
    behind, 8e-5 of the slowest one's 3 m travel against a bound of 4e-13."""
    from refsim.scene import Plates
    scene = CASE.scene

    def thicker(p):
        s = scene(p)
        plate = s.part(Plates)
        wide = Plates(center=plate.center, normal=plate.normal,
                      thickness=1.1 * plate.thickness, half_size=plate.half_size)
        return type(s)(parts=tuple(wide if part is plate else part for part in s.parts),
                       contact=s.contact)
    monkeypatch.setattr(CASE, "scene", thicker)
    row = _row(formulation)
    assert row["consistency"] == "inconsistent"
    if formulation == "discrete":
        assert row["tunnelled"] == 4 and row["threshold_ratio"] == 1.5
        assert "tunnelled 4" in row["consistency_reason"]
    else:
        assert row["err_max"] > 1e8 * row["tolerance"]


def test_a_plate_side_the_case_does_not_know_is_a_reason():
    row = {"tunnelled": 5.0, "threshold_ratio": 1.002, "late_bounce_err": 0.0}
    reasons = CASE.consistency_checks(THRESHOLD, row, {"detection": "discrete",
                                                       "plate_side": "sideways"})
    assert reasons and "plate_side" in reasons[0]


def test_no_projection_leaves_from_the_overlap_and_is_told_apart(monkeypatch):
    """refsim with its positional projection off (the velocity alone reverses, as pybullet and
    pymunk do): every bounced sphere leaves from where its step ended (depth 1), the tunnelled
    set unchanged; declared 'face' it is caught, declared 'none' it is consistent, its error
    (d* + w/2 + r more per sphere) within the 'none' theory's bound."""
    from refsim_adapters.refsim_engine import contacts
    monkeypatch.setattr(contacts.col, "project_walls", lambda x, s, normals, depth: None)
    row = _row("discrete")
    assert row["tunnelled"] == 5
    assert row["bounce_depth_min"] == pytest.approx(1.0, abs=1e-12)  # round-off, as above
    assert row["bounce_depth_max"] == pytest.approx(1.0, abs=1e-12)
    assert row["consistency"] == "inconsistent" and "bounce depth" in row["consistency_reason"]
    settings = {"detection": "discrete", "plate_side": "approach", "plate_projection": "none"}
    assert CASE.consistency_checks(THRESHOLD, row, settings) == []
    bound, _ = CASE.tolerance(THRESHOLD, "symplectic_euler", 1, 0.01, "", settings)
    face, _ = CASE.tolerance(THRESHOLD, "symplectic_euler", 1, 0.01, "",
                             {**settings, "plate_projection": "face"})
    assert face < row["err_max"] <= bound


def test_an_unknown_projection_is_a_reason():
    reasons = CASE.consistency_checks(THRESHOLD, {"tunnelled": 5.0}, {
        "detection": "discrete", "plate_side": "approach", "plate_projection": "half"})
    assert reasons and "plate_projection" in reasons[0]
