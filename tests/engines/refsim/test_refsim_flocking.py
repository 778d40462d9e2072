"""The in-house flocking and emitter groups: conservation, orders, counts, and the slide's
sprinkler as printed. Every emitted particle on the exact discrete parabola of its stepper, as on
taichi, is checked in tests/conformance/test_conformance_emitter.py."""
import numpy as np
import pytest

from refsim_cases.flocking.boids import CASE as BOIDS
from refsim_cases.emitter.sprinkler import CASE as EMITTER
from refsim.models import emitter as em
from refsim.registry import get_engine

ENGINE = get_engine("refsim")
EPS = np.finfo(float).eps
FLOCK_STEPPERS = ("explicit_euler", "symplectic_euler", "midpoint", "rk4", "velocity_verlet",
                  "stormer_verlet", "leapfrog")


def _run(case, variant, integrator, dt, formulation="", t_end=None):
    p = case.variant_params(variant)
    sim = ENGINE.build(case.scene(p), dt, integrator, formulation)
    out = [sim.observe()]
    for _ in range(int(round((t_end or case.t_end(p)) / dt / 10))):
        sim.step(10)
        out.append(sim.observe())
    return p, {k: np.array([o[k] for o in out]) for k in out[0]}


@pytest.mark.parametrize("integrator", FLOCK_STEPPERS)
def test_cucker_smale_mean_velocity_kept_to_round_off_and_variance_decays(integrator):
    p, obs = _run(BOIDS, "cucker_smale", integrator, 0.02)
    mean = obs["v"].mean(axis=1)
    # each step adds h sum_i a_i, zero up to N eps |a| (pair cancellation): 100 steps x a few
    # of those, |a| <= 2 K max|v| = 4 m/s^2
    assert np.abs(mean - mean[0]).max() <= 100 * 24 * EPS * 4 * 0.02 * 10
    var = BOIDS.observables(p, obs)["velocity_variance"]
    assert var[-1] < 0.1 * var[0]


def test_reynolds_mean_velocity_drifts():
    p, obs = _run(BOIDS, "reynolds", "rk4", 0.02)
    mean = obs["v"].mean(axis=1)
    assert np.abs(mean - mean[0]).max() > 1e-3


@pytest.mark.parametrize("integrator,order", [("explicit_euler", 1), ("midpoint", 2),
                                              ("rk4", 4), ("velocity_verlet", 2)])
def test_boids_converge_at_the_nominal_order(integrator, order):
    errors = []
    for dt in (0.04, 0.02):
        p, obs = _run(BOIDS, "cucker_smale", integrator, dt)
        ref = BOIDS.reference(p, obs["t"])
        errors.append(np.abs(obs["x"] - ref["x"]).max())
    # the ratio of two errors one halving apart: 2^p up to the next term, O(h) relative
    assert np.log2(errors[0] / errors[1]) == pytest.approx(order, abs=0.2)


@pytest.mark.parametrize("dt", [0.01, 0.004])
def test_counts_match_rate_times_time_to_the_step_rounding(dt):
    p, obs = _run(EMITTER, "default", "rk4", dt, "corrected")
    e = EMITTER.emitter(p)
    alive = (obs["id"] >= 0).sum(axis=1)
    assert np.abs(alive - em.continuum_alive(e, obs["t"])).max() <= em.count_bound(e, dt)
    assert np.array_equal(obs["emitted"], em.emitted_count(e, dt, np.rint(obs["t"] / dt)))


def test_as_printed_flies_straight_and_over_counts():
    dt = 0.01
    p, obs = _run(EMITTER, "default", "rk4", dt, "as_printed")
    observed = EMITTER.observables(p, obs)
    # the straight line misses the parabola by g a^2 / 2 at age a: the oldest, a = L h - h
    age = (em.life_steps(EMITTER.emitter(p), dt) - 1) * dt
    assert observed["position_error"].max() == pytest.approx(0.5 * p["g"] * age ** 2, rel=1e-9)
    # k = 1 at each of the T / h + 1 boundaries: k / (rate h) = 2 times rate T + 1
    steps = round(p["duration"] / dt)
    assert obs["emitted"][-1] == steps + 1 and p["rate"] * p["duration"] == steps / 2


def test_emitter_settings_state_the_capacity_and_formulation():
    p = EMITTER.variant_params("default")
    sim = ENGINE.build(EMITTER.scene(p), 0.01, "rk4", "as_printed")
    s = sim.settings()
    assert s["capacity"] == 50 and "velocity == g*dt" in s["formulation"]
    assert ENGINE.formulations(EMITTER.scene(p)) == ("corrected", "as_printed")
