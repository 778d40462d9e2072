"""taichi's flocking kernels equal refsim's group to round-off over the boids case's default
run, per stepper; the Cucker-Smale mean velocity is kept to round-off; Reynolds agrees too."""
import numpy as np
import pytest

pytest.importorskip("taichi")

from refsim_cases.flocking.boids import CASE as BOIDS
from refsim.registry import get_engine
from refsim.scene import Particles

EPS = np.finfo(float).eps
STEPPERS = ("symplectic_euler", "velocity_verlet", "rk4", "explicit_euler", "midpoint")
EVALS = {"symplectic_euler": 1, "velocity_verlet": 2, "rk4": 4, "explicit_euler": 1,
         "midpoint": 2}


def _run(engine, p, integrator, dt):
    """Observations every 10 steps over the case's run."""
    sim = get_engine(engine).build(BOIDS.scene(p), dt, integrator)
    out = [sim.observe()]
    for _ in range(round(BOIDS.t_end(p) / dt / 10)):
        sim.step(10)
        out.append(sim.observe())
    settings = sim.settings()
    sim.close()
    return {k: np.array([o[k] for o in out]) for k in out[0]}, settings


def _scales(p):
    """(N, psi_max, V, S): birds, max psi = K / sigma^(2 beta), max |v| (Cucker-Smale
    velocities stay in the convex hull of the start's: max |v| never grows), and the state
    scale max |x| + V T."""
    x, v = BOIDS.initial_state(p)
    speed = float(np.max(np.linalg.norm(v, axis=1)))
    return (len(x), p["K"] / p["sigma"] ** (2 * p["beta"]), speed,
            float(np.max(np.abs(x))) + speed * p["duration"])


@pytest.mark.parametrize("integrator", STEPPERS)
@pytest.mark.parametrize("dt", BOIDS.dts(BOIDS.variant_params("cucker_smale")))
def test_taichi_equals_refsim_over_the_default_run(integrator, dt):
    p = BOIDS.variant_params("cucker_smale")
    tai, settings = _run("taichi", p, integrator, dt)
    ref, _ = _run("refsim", p, integrator, dt)
    # same operations: t = steps * dt in both Sims
    assert np.array_equal(tai["t"], ref["t"])
    n, psi, speed, state = _scales(p)
    steps = round(BOIDS.t_end(p) / dt)
    # the two sum the pair terms in another order (refsim: psi @ v - (sum_j psi) v, taichi:
    # sum_j psi (v_j - v_i)): each a_i differs by <= 2 x N eps x 2 psi_max V (N terms of
    # size <= 2 psi_max V, over N), so a step's kicks (b-weights summing to 1) differ by
    # <= h 4 N eps psi_max V, carried into x over the rest of the run (x T); plus each step's
    # rounding of the state, eps S. The flow does not amplify them: at fixed x the velocity
    # linearisation is minus a graph Laplacian (contractive). l2 over the N birds: sqrt(N).
    per_step = EPS * (state + 4 * n * psi * speed * dt * p["duration"])
    bound = steps * np.sqrt(n) * per_step
    assert np.max(np.linalg.norm(tai["x"] - ref["x"], axis=(1, 2))) <= bound
    v_bound = steps * np.sqrt(n) * EPS * (speed + 4 * n * psi * speed * dt)
    assert np.max(np.linalg.norm(tai["v"] - ref["v"], axis=(1, 2))) <= v_bound
    assert settings["dtype"] == "float64" and settings["default_fp"].endswith("f64")
    assert settings["rule"] == "cucker_smale" and settings["K"] == p["K"]


def _mean_velocity_roundoff(p, integrator, dt, steps):
    """How far the mean velocity may move by round-off alone over `steps` steps. The computed
    pair terms psi_ij (v_j - v_i) are exact negatives (|d|^2 and v_j - v_i are exact under
    i <-> j), so sum_i a_i is only the rounding of the N sums, <= N x N eps x 2 psi_max V: the
    mean moves by <= h 2 N eps psi_max V per evaluation, plus eps V for rounding each v_i
    update; E evaluations a step; plus 2 N eps V for the two numpy means compared."""
    n, psi, speed, _ = _scales(p)
    return (steps * EVALS[integrator] * EPS * speed * (2 * n * psi * dt + 1)
            + 2 * n * EPS * speed)


@pytest.mark.parametrize("integrator", STEPPERS)
def test_cucker_smale_mean_velocity_kept_to_round_off(integrator):
    p = BOIDS.variant_params("cucker_smale")
    dt = BOIDS.dts(p)[-1]
    obs, _ = _run("taichi", p, integrator, dt)
    mean = obs["v"].mean(axis=1)
    steps = round(BOIDS.t_end(p) / dt)
    assert np.max(np.abs(mean - mean[0])) <= _mean_velocity_roundoff(p, integrator, dt, steps)
    var = BOIDS.observables(p, obs)["velocity_variance"]
    assert var[-1] < 0.5 * var[0]  # the flock aligns: the variance decays (Ha & Liu bound)


def test_reynolds_agrees_step_by_step_and_drifts():
    p = BOIDS.variant_params("reynolds")
    dt, steps = 0.02, 10
    sims = [get_engine(e).build(BOIDS.scene(p), dt, "rk4") for e in ("taichi", "refsim")]
    gap, r_min = 0.0, np.inf
    for _ in range(steps):
        for sim in sims:
            sim.step(1)
        tai, ref = (sim.observe() for sim in sims)
        gap = max(gap, np.linalg.norm(tai["x"] - ref["x"]))
        d = np.linalg.norm(ref["x"][:, None] - ref["x"][None], axis=-1)
        r_min = min(r_min, np.min(d + np.diag(np.full(len(d), np.inf))))
    n, _, speed, state = _scales(p)
    # short (the rule jumps where a bird crosses the radius: over a long run a round-off
    # difference could flip a neighbour). Round-off as above: the neighbour sums' order,
    # N eps x the largest term (w_s / r_min, w_a 2V, w_c 2 max|x|) per evaluation, carried
    # over the run (h T), plus eps S per step; sqrt(N) for the l2 norm
    term = (p["separation"] / r_min + p["alignment"] * 2 * speed
            + p["cohesion"] * 2 * float(np.max(np.abs(ref["x"]))))
    bound = steps * np.sqrt(n) * EPS * (state + 2 * n * term * dt * steps * dt)
    assert gap <= bound
    assert sims[0].settings()["rule"] == "reynolds"
    # not conserved: the mean moves far beyond the round-off Cucker-Smale keeps it to
    start = BOIDS.scene(p).part(Particles).velocity
    drift = np.linalg.norm(tai["v"].mean(axis=0) - start.mean(axis=0))
    assert drift > 1e6 * _mean_velocity_roundoff(p, "rk4", dt, steps)


def test_flocking_refuses_other_steppers_with_the_reason():
    engine = get_engine("taichi")
    scene = BOIDS.scene(BOIDS.variant_params("cucker_smale"))
    assert engine.supports(scene) is None
    assert engine.offered_integrators(scene) == STEPPERS
    reason = engine.supports(scene, "leapfrog")
    assert reason is not None and "leapfrog" in reason
    with pytest.raises(ValueError, match="integrator"):
        engine.build(scene, 0.02, "leapfrog")
