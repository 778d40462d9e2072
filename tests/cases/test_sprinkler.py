"""Emitter case: its reference counts and the tolerances it derives."""
import numpy as np

from cases.particle_fields.sprinkler import CASE
from refsim.models import emitter as em


def test_reference_counts_are_rate_times_time():
    p = CASE.variant_params("default")
    t = np.linspace(0.0, p["duration"], 401)
    ref = CASE.reference(p, t)
    # alive: rate x min(t, lifetime), to one particle (the floor of each end)
    assert np.all(np.abs(ref["alive"] - p["rate"] * np.minimum(t, p["lifetime"])) <= 1.0)
    assert ref["emitted"][-1] == p["rate"] * p["duration"] + 1


def test_first_order_tolerance_is_the_exact_lag_plus_round_off():
    p = CASE.variant_params("default")
    tol_euler, _ = CASE.tolerance(p, "explicit_euler", 1, 0.01)
    tol_rk4, reason = CASE.tolerance(p, "rk4", 4, 0.01)
    assert tol_euler - tol_rk4 == 0.5 * p["g"] * 0.01 * p["lifetime"]
    assert tol_rk4 < 1e-11 and "round-off" in reason
    assert CASE.order_meaningful is False
    # floor(rate L h) + 1 with L h = lifetime = 0.5 s (h divides it): 25 + 1
    assert em.capacity(CASE.emitter(p), 0.01) == 26
