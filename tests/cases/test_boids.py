"""Boids case: the converged reference, flocking against Ha & Liu's bound, the figure."""
import numpy as np

from cases.particle_fields.boids import CASE
from refsim.models.flocking import velocity_variance


def test_reference_keeps_the_mean_velocity_and_flocks_within_the_bound():
    p = CASE.variant_params("cucker_smale")
    t = np.linspace(0.0, CASE.t_end(p), 21)
    ref = CASE.reference(p, t)
    x0, v0 = CASE.initial_state(p)
    assert np.abs(ref["x"][0] - x0).max() <= 1e-12 * np.abs(x0).max()
    var = ref["velocity_variance"]
    assert np.all(np.diff(var) < 0)  # d|V|^2/dt <= -2 psi(D) |V|^2 < 0
    # the flow's bound, met by a solution accurate to rtol = 1e-12 (relative)
    assert np.all(var[1:] <= CASE.variance_bound(p, t[1:]) * (1 + 1e-9))
    assert var[-1] < 0.1 * var[0]


def test_figure_is_the_bound_curve():
    p = CASE.variant_params("cucker_smale")
    (figure,) = CASE.figures(p)
    assert figure["y"] == "velocity_variance" and figure["x"] == "t"
    assert figure["data"]["y"][0] == velocity_variance(CASE.initial_state(p)[1])


def test_reynolds_variant_has_no_bound_figure():
    assert CASE.figures(CASE.variant_params("reynolds")) == []
