"""The pybullet adapter: exact agreement with refsim's kick-drift symplectic Euler, measured
order and stability limit, tolerances at the reference dt, settings and failure reporting.

pybullet is imported here on purpose: CI must have every engine, so a missing package fails at
import instead of skipping (docs/engine_notes.md#pybullet facts were measured on pybullet
3.2.7).
"""
import json
import math
import os

import numpy as np
import pybullet  # noqa: F401  (fail, never skip, without the engine)
import pytest

from refsim.registry import get_engine
from refsim.registry import get_case
from refsim.run.metrics import bisect_limit
from refsim.run.job import Job, run_job
from refsim.scene import Body, Joint, Joints, Particles, Scene, Spring, Springs
from refsim.testing import accuracy, assert_consistent, measured_order

ENGINE = get_engine("pybullet")
REFSIM = get_engine("refsim")
SE = "symplectic_euler"


# ---------------------------------------------------------------------------------------------
# 1. Exact discrete agreement with refsim's kick-drift symplectic Euler
# ---------------------------------------------------------------------------------------------
def _case_scene(name, variant, **params):
    case = get_case(name)
    p = case.variant_params(variant, params)
    return case.scene(p), case.reference_dt(p), int(round(case.t_end(p) / case.reference_dt(p)))


def _pendulum_with_drag():
    L, th = 0.8, 1.2
    bob = Body(mass=0.7, position=(L * np.sin(th), 0.0, -L * np.cos(th)), name="bob")
    rod = Joint(body=0, anchor=(0.0, 0.0, 0.0), length=L)
    return Scene(parts=(Particles.of((bob,)), Joints.of((rod,))), gravity=(0.0, 0.0, -9.81),
                 linear_drag=0.3, planar=True), 1e-3, 2000


def _two_bodies_springs_drag():
    """Two free bodies, a damped spring between them and one to an anchor, gravity and drag:
    every force path of the adapter (both spring ends, damping, drag) at once."""
    a = Body(mass=1.0, position=(1.2, 0.1, 0.0), velocity=(0.0, 0.5, 0.2), name="a")
    b = Body(mass=2.0, position=(2.0, -0.3, 0.4), velocity=(0.3, 0.0, 0.0), name="b")
    springs = (Spring(body=0, stiffness=400.0, rest_length=1.0, damping=2.0),
               Spring(body=0, other=1, stiffness=900.0, rest_length=0.7, damping=5.0))
    return Scene(parts=(Particles.of((a, b)), Springs.of(springs)), gravity=(0.0, 0.0, -9.81),
                 linear_drag=0.2), 1e-3, 2000


AGREEMENT = {
    "free_fall/default": lambda: _case_scene("free_fall", "default"),
    "free_fall/drag": lambda: _case_scene("free_fall", "drag"),
    "stiff_spring/default": lambda: _case_scene("stiff_spring", "default"),
    "stiff_spring/underdamped": lambda: _case_scene("stiff_spring", "underdamped"),
    "stiff_spring/k=1e6": lambda: _case_scene("stiff_spring", "k=1e6"),  # beyond 100 m/s
    "pendulum/default": lambda: _case_scene("pendulum", "default", duration=3.0),
    "pendulum/large_amplitude": lambda: _case_scene("pendulum", "large_amplitude",
                                                    duration=3.0),
    "pendulum+drag": _pendulum_with_drag,
    "two_bodies+springs+drag": _two_bodies_springs_drag,
}


@pytest.mark.parametrize("label", AGREEMENT)
def test_agrees_with_refsim_kick_drift(label):
    """Same dt, same method: positions and velocities agree to 1e-9 m and m/s at every 10th
    step (docs/engine_notes.md#pybullet-default-velocity-damping: ~1e-13 once damping, clamp
    and motor are off)."""
    scene, dt, steps = AGREEMENT[label]()
    sims = [ENGINE.build(scene, dt, SE),
            REFSIM.build(scene, dt, SE, "generalized" if scene.part(Joints) else "")]
    worst = 0.0
    try:
        for _ in range(steps // 10):
            obs = []
            for sim in sims:
                sim.step(10)
                obs.append(sim.observe())
            assert obs[0]["t"] == pytest.approx(obs[1]["t"], abs=1e-12)
            worst = max(worst, *(np.max(np.abs(obs[0][k] - obs[1][k])) for k in ("x", "v")))
    finally:
        for sim in sims:
            sim.close()
    assert worst < 1e-9, worst


def test_free_fall_is_the_closed_form_semi_implicit_euler():
    """z_k = z0 + k dt v0 - k(k+1)/2 dt^2 g; at t = 1 s, dt = 1e-3 the error is -g t dt / 2."""
    case = get_case("free_fall")
    p = case.variant_params("default")
    dt, n = 1e-3, 1000
    sim = ENGINE.build(case.scene(p), dt, SE)
    sim.step(n)
    z = sim.observe()["x"][0, 2]
    sim.close()
    k = n
    assert z == pytest.approx(p["height"] + k * dt * p["vz0"] - k * (k + 1) / 2 * dt * dt * p["g"],
                              abs=1e-12)
    exact = p["height"] + p["vz0"] - 0.5 * p["g"]
    assert z - exact == pytest.approx(-4.905e-3, rel=1e-9)


# ---------------------------------------------------------------------------------------------
# 2. Measured convergence order (least-squares slope over halving dts, asymptotic range)
# ---------------------------------------------------------------------------------------------
Y_COARSE = 0.01  # w dt at the coarsest step: asymptotic for a first-order method


def _sweep(omega):
    return [Y_COARSE / omega / 2 ** k for k in range(4)]


@pytest.mark.parametrize("case,omega,params", [
    ("stiff_spring", 100.0, {"periods": 1.0}),
    ("pendulum", 2.0 * math.sqrt(9.81), {"duration": 2.0}),  # swing + nonlinearity ~ 2 w0
    ("free_fall", 1.0, {"duration": 1.0}),
])
def test_measured_order_is_one(case, omega, params):
    slope, used, errs = measured_order(case, "default", "pybullet", SE, _sweep(omega), "",
                                       **params)
    assert used >= 3, errs
    assert abs(slope - 1.0) < 0.15, (slope, errs)


# ---------------------------------------------------------------------------------------------
# 3. Measured stability limit on the undamped spring, y = w0 dt
# ---------------------------------------------------------------------------------------------
# Criterion: every state finite and E < 1e3 E0 at every step over max(100 periods, 1000 steps).
# Why 1e3 and not 10: below the limit symplectic Euler's orbit is a tilted ellipse on which the
# true energy reaches E0 / (1 - y/2), which passes 10 E0 at y = 1.8 although the step is
# stable; 1e3 E0 puts that threshold at y = 1.998, within 0.1 % of the limit. Above y = 2 the
# amplitude grows by about 1 + sqrt(4 (y - 2)) per step (linearly at y = 2), so the bound is
# crossed within the run. The rest length is 1000 m (A = 0.1 m): the default 1 m would let the
# orbit (amplitude up to sqrt(1e3) A) pass through the anchor, where the spring is no longer
# linear, and the search would then find 1.99 instead of the linear step's limit.
ENERGY_BOUND, PERIODS, MIN_STEPS = 1e3, 100, 1000


def _spring_stays_bounded(y):
    case = get_case("stiff_spring")
    p = case.variant_params("default", {"rest_length": 1000.0})
    sim = ENGINE.build(case.scene(p), y / case.omega(p), SE)
    e0 = case.energy_scale(p)
    try:
        for _ in range(max(MIN_STEPS, math.ceil(PERIODS * 2 * math.pi / y))):
            sim.step(1)
            o = sim.observe()
            if not (np.all(np.isfinite(o["x"])) and np.all(np.isfinite(o["v"]))):
                return False
            u = o["x"][0, 0] - p["rest_length"]
            energy = 0.5 * p["mass"] * np.sum(o["v"][0] ** 2) + 0.5 * p["stiffness"] * u * u
            if energy >= ENERGY_BOUND * e0:
                return False
    finally:
        sim.close()
    return True


def test_stability_limit_is_two():
    limit = bisect_limit(_spring_stays_bounded, 1.0, 3.0, tol=1e-4)
    assert limit == pytest.approx(2.0, rel=0.01), limit


def _one_step_matrix(y, k=1e4, m=1.0, rest=1.0, a=1e-3):
    """The engine's one-step map on (u, v / w0), measured from two unit-ish states (the spring
    along x is linear in u)."""
    w0 = math.sqrt(k / m)
    cols = []
    for u0, v0 in ((a, 0.0), (0.0, a * w0)):
        body = Body(mass=m, position=(rest + u0, 0.0, 0.0), velocity=(v0, 0.0, 0.0))
        scene = Scene(parts=(Particles.of((body,)),
                             Springs.of((Spring(body=0, stiffness=k, rest_length=rest),))))
        sim = ENGINE.build(scene, y / w0, SE)
        sim.step(1)
        o = sim.observe()
        sim.close()
        cols.append([(o["x"][0, 0] - rest) / a, o["v"][0, 0] / w0 / a])
    return np.array(cols).T


def test_measured_step_matrix_is_kick_drift_with_spectral_limit_two():
    """A sharper measurement: the engine's own one-step map is [[1 - y^2, y], [-y, 1]] (kick-
    drift), whose spectral radius stays 1 up to y = 2 exactly."""
    for y in (0.3, 1.5, 2.5):
        np.testing.assert_allclose(_one_step_matrix(y), [[1 - y * y, y], [-y, 1.0]],
                                   atol=1e-9)
    radius = lambda y: np.max(np.abs(np.linalg.eigvals(_one_step_matrix(y))))  # noqa: E731
    limit = bisect_limit(lambda y: radius(y) <= 1 + 1e-6, 1.0, 3.0, tol=1e-7)
    assert limit == pytest.approx(2.0, abs=1e-5), limit


# ---------------------------------------------------------------------------------------------
# 4. Every case variant within its tolerance at the reference dt (full runs via the runner)
# ---------------------------------------------------------------------------------------------
VARIANTS = [(c, v) for c in ("free_fall", "stiff_spring", "pendulum")
            for v in get_case(c).variants]


@pytest.mark.parametrize("case,variant", VARIANTS)
def test_within_tolerance_at_reference_dt(case, variant):
    row = assert_consistent(case, "pybullet", SE, variant=variant)
    assert row["status"] == "ok" and (row["consistency"] == "consistent")
    assert row["constraint_drift"] == 0.0 or case != "pendulum"  # generalized coordinates


def test_runner_row_with_timing_is_ok_first_order_and_timed():
    case = get_case("stiff_spring")
    p = case.variant_params("default")
    row = run_job(Job("stiff_spring", "default", "pybullet", "", SE, case.reference_dt(p)),
                  repeats=1, budget_s=0.0)
    assert row["status"] == "ok" and (row["consistency"] == "consistent"), row["reason"]
    assert row["nominal_order"] == 1.0 and row["us_per_step"] > 0
    assert row["engine_version"] not in ("", "unknown")


def test_speed_above_the_default_clamp_is_kept():
    """Default multibody speed clamp is 100 m/s
    (docs/engine_notes.md#pybullet-multibody-speed-clamp): raised, a 150 m/s throw is still
    exact to first order."""
    row = accuracy("free_fall", "default", "pybullet", SE, 1e-3, vx0=150.0, vz0=120.0)
    assert row["status"] == "ok" and (row["consistency"] == "consistent"), (row["err_max"], row["tolerance"])


# ---------------------------------------------------------------------------------------------
# 5. Settings report every docs/engine_notes.md fix; divergence is reported; bad input is a
#    ValueError
# ---------------------------------------------------------------------------------------------
def _settings(name, variant="default"):
    scene, dt, _ = _case_scene(name, variant)
    sim = ENGINE.build(scene, dt, SE)
    try:
        return sim, sim.settings(), dt, scene
    finally:
        sim.close()


def test_settings_report_engine_notes_fixes():
    _, s, dt, scene = _settings("pendulum")
    json.dumps(s, allow_nan=False)  # strict JSON
    assert s["integrator"] == {"name": SE, "order": 1, "family": "symplectic Euler",
                               "explicit": True, "symplectic": True,
                               "native": s["integrator"]["native"]}
    assert "semi-implicit Euler" in s["integrator"]["native"]
    assert s["dtype"] == "float64" and s["threads"] == 1 and s["connection"] == "DIRECT"
    assert s["fixedTimeStep"] == dt and s["numSubSteps"] == 0
    assert s["gravity"] == list(scene.gravity)
    assert s["linearDamping"] == s["angularDamping"] == s["jointDamping"] == 0.0
    assert s["maxJointVelocity"].startswith("inf")
    assert "force=0" in s["velocity_motor"] and s["joint_limits"] == "none"
    assert "as given" in s["inertia"] and s["sleeping"] == "disabled"
    assert s["formulation"].startswith("generalized")


def test_settings_state_the_per_step_python_cost():
    _, s, _, _ = _settings("stiff_spring", "underdamped")
    assert s["external_forces"] == ["springs (external force)"]
    assert "applyExternalForce" in s["external_force_method"]
    assert "real cost" in s["python_per_step_note"]
    assert s["python_calls_per_step"] == 4  # position, velocity, force, step
    _, s, _, _ = _settings("free_fall", "drag")
    assert s["external_forces"] == ["drag (external force)"]
    _, s, _, _ = _settings("free_fall")
    assert s["python_calls_per_step"] == 1 and s["external_forces"] == "none"


def test_engine_state_matches_the_settings():
    """Read back from pybullet itself: joint damping 0, no joint limits, the step and gravity."""
    scene, dt, _ = _case_scene("pendulum", "default")
    sim = ENGINE.build(scene, dt, SE)
    p, cid = sim.p, sim.client
    try:
        uid, link = sim.handles[0]
        info = p.getJointInfo(uid, link, physicsClientId=cid)
        assert info[2] == p.JOINT_REVOLUTE and info[6] == 0.0  # jointDamping
        assert info[8] > info[9]  # lower > upper: no limit
        prm = p.getPhysicsEngineParameters(physicsClientId=cid)
        assert prm["fixedTimeStep"] == dt and prm["numSubSteps"] == 0
        assert prm["gravityAccelerationZ"] == scene.gravity[2]
        x = sim.observe()["x"][0]
        np.testing.assert_allclose(x, scene.part(Particles).position[0], atol=1e-15)  # theta0 sign
    finally:
        sim.close()


def test_explicit_instability_is_reported_as_diverged():
    case = get_case("stiff_spring")
    p = case.variant_params("default")
    row = run_job(Job("stiff_spring", "default", "pybullet", "", SE, 2.5 / case.omega(p)),
                  repeats=0)
    assert row["status"] == "diverged" and "energy" in row["reason"], row["reason"]


def test_unsupported_scenes_are_refused_and_bad_dt_or_formulation_raise():
    scene, dt, _ = _case_scene("stiff_spring", "default")
    assert "rk4" in ENGINE.supports(scene, "rk4")
    with pytest.raises(ValueError, match="rk4"):
        ENGINE.build(scene, dt, "rk4")
    for bad in (0.0, -1e-3, float("nan")):
        with pytest.raises(ValueError, match="dt"):
            ENGINE.build(scene, bad, SE)
    with pytest.raises(ValueError, match="formulation"):
        ENGINE.build(scene, dt, SE, "kkt")
    flat = Scene(parts=(Particles.of((Body(mass=1.0, position=(0.0, 1.0, 0.0)),)),), dim=2)
    assert "3D" in ENGINE.supports(flat)
    off_rod = Scene(parts=(Particles.of((Body(mass=1.0, position=(0.5, 0.0, -0.5)),)),
                           Joints.of((Joint(body=0, anchor=(0.0, 0.0, 0.0), length=1.0),))),
                    gravity=(0.0, 0.0, -9.81))
    assert "rod" in ENGINE.supports(off_rod)
    row = run_job(Job("stiff_spring", "default", "pybullet", "", "rk4", dt), repeats=0)
    assert row["status"] == "unsupported"


def test_close_is_idempotent_and_nothing_is_written(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    scene, dt, _ = _case_scene("pendulum", "default")
    sim = ENGINE.build(scene, dt, SE)
    sim.step(100)
    sim.close()
    sim.close()
    assert os.listdir(tmp_path) == []
