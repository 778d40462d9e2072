"""The MuJoCo adapter (mujoco 4.0.0): exact discrete agreement with refsim, convergence orders,
stability limits, runs at the reference dt, reported settings and divergence handling.

mujoco is imported at module level on purpose: CI must have all four engines, so a missing
package fails here instead of skipping.
"""
from __future__ import annotations

import json
import math
import os

import mujoco  # noqa: F401  (fail, never skip, when the engine is missing)
import numpy as np
import pytest

from refsim.registry import get_engine
from refsim_adapters.mujoco_engine.methods import METHODS
from refsim_adapters.mujoco_engine.point_masses import POINT_INERTIA
from refsim.registry import get_case
from refsim.run.metrics import bisect_limit, convergence_order
from refsim.integrators import method_info
from refsim.run.job import Job, run_job
from refsim.scene import Body, Joint, Joints, Particles, Scene, Spring, Springs

ENGINE = get_engine("mujoco")
REFSIM = get_engine("refsim")


def _case(name, variant="default", **over):
    case = get_case(name)
    p = case.variant_params(variant, over)
    return case, p, case.scene(p)


def _max_difference(a, b, steps, chunk):
    """Largest |x_a - x_b|, |v_a - v_b| over `steps` steps, compared every `chunk` steps."""
    worst = max(np.max(np.abs(a.observe()["x"] - b.observe()["x"])), 0.0)
    for _ in range(steps // chunk):
        a.step(chunk)
        b.step(chunk)
        oa, ob = a.observe(), b.observe()
        assert oa["t"] == pytest.approx(ob["t"], rel=1e-12)
        worst = max(worst, np.max(np.abs(oa["x"] - ob["x"])), np.max(np.abs(oa["v"] - ob["v"])))
    return worst


# ---------------------------------------------------------------------------------------------
# 1. Exact discrete agreement with the in-house engine
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name,variant,ours,theirs", [
    ("free_fall", "default", "symplectic_euler", "symplectic_euler"),
    ("free_fall", "drag", "symplectic_euler", "symplectic_euler"),  # eulerdamp disabled
    ("stiff_spring", "default", "symplectic_euler", "symplectic_euler"),
    ("stiff_spring", "underdamped", "symplectic_euler", "symplectic_euler"),
    ("pendulum", "default", "symplectic_euler", "symplectic_euler"),
    ("pendulum", "large_amplitude", "symplectic_euler", "symplectic_euler"),
    # backward Euler is what discrete (and implicit damping on free fall) reduces to here
    ("stiff_spring", "default", "discrete", "implicit_euler"),
    ("stiff_spring", "underdamped", "discrete", "baraff_witkin"),
    ("free_fall", "drag", "implicitfast", "implicit_euler"),
    ("free_fall", "drag", "implicit", "implicit_euler"),
    ("stiff_spring", "default", "rk4", "rk4"),
])
def test_exact_discrete_agreement_with_refsim(name, variant, ours, theirs):
    case, p, scene = _case(name, variant)
    dt = case.reference_dt(p)
    a = ENGINE.build(scene, dt, ours)
    b = REFSIM.build(scene, dt, theirs, "generalized" if scene.part(Joints) else "")
    steps = min(case_steps(case, p, dt), 3000)
    assert _max_difference(a, b, steps, chunk=50) <= 1e-9
    assert a.failure is None


def case_steps(case, p, dt):
    return int(round(case.t_end(p) / dt))


def test_pendulum_starts_on_the_scene_pose_and_swings_down():
    case, p, scene = _case("pendulum")
    sim = ENGINE.build(scene, 1e-3, "symplectic_euler")
    o = sim.observe()
    np.testing.assert_allclose(o["x"], scene.part(Particles).position, atol=1e-15)
    np.testing.assert_allclose(o["v"], 0.0, atol=1e-15)
    np.testing.assert_array_equal(o["constraint"], [0.0])
    sim.step(10)
    theta = case.observables(p, {k: np.asarray([v]) for k, v in sim.observe().items()})["theta"]
    assert 0 < theta[0] < p["theta0"]


# ---------------------------------------------------------------------------------------------
# 2. Convergence orders
# ---------------------------------------------------------------------------------------------
def _measured_order(name, variant, integrator, dts, **over):
    case = get_case(name)
    p = case.variant_params(variant, over)
    params = tuple(sorted(over.items()))
    errs = [run_job(Job(name, variant, "mujoco", "", integrator, dt, params), repeats=1,
                    budget_s=0.0)["err_max"] for dt in dts]
    return convergence_order(dts, errs, case.error_floor(p), case.error_ceiling(p))


SPRING_DTS = [y / 100.0 for y in (0.2, 0.1, 0.05, 0.025)]  # y = w0 dt, w0 = 100 rad/s


@pytest.mark.parametrize("integrator", ["symplectic_euler", "rk4", "implicit", "implicitfast"])
@pytest.mark.parametrize("variant", ["default", "underdamped"])
def test_measured_order_on_stiff_spring_is_declared_order(integrator, variant):
    order, used = _measured_order("stiff_spring", variant, integrator, SPRING_DTS, periods=1.0)
    assert used >= 3
    assert order == pytest.approx(METHODS[integrator].order, abs=0.15)


def test_discrete_is_first_order_on_stiff_spring():
    """Backward Euler's amplitude loss (1 - (1+y^2)^(-n/2) ~ w0 t y / 2) is first order."""
    dts = [y / 100.0 for y in (0.025, 0.0125, 0.00625)]
    order, used = _measured_order("stiff_spring", "default", "discrete", dts, periods=1.0)
    assert used == 3
    assert order == pytest.approx(1.0, abs=0.15)


@pytest.mark.parametrize("integrator,dts", [
    ("symplectic_euler", [4e-3, 2e-3, 1e-3, 5e-4]),
    ("implicitfast", [4e-3, 2e-3, 1e-3, 5e-4]),
    ("rk4", [8e-3, 4e-3, 2e-3, 1e-3]),
])
def test_measured_order_on_pendulum_is_declared_order(integrator, dts):
    order, used = _measured_order("pendulum", "default", integrator, dts, duration=2.0)
    assert used >= 3
    assert order == pytest.approx(METHODS[integrator].order, abs=0.15)


# ---------------------------------------------------------------------------------------------
# 3. Stability limits on the undamped spring (w0 = 100 rad/s)
# ---------------------------------------------------------------------------------------------
STABILITY_PERIODS = 1000
ENERGY_BOUND = 1e4  # x E0. Symplectic Euler from rest peaks at E0 / (1 - y/2): this bound
# moves its measured limit by 2e-4 (0.01 %) only; unstable steps grow by >= 1.09 per step 0.1 %
# past the limit, so 1000 periods (>= 3000 steps) leave no doubt.


def _stable(integrator, y):
    """Criterion: finite, no engine failure and E <= 1e4 E0 at every 100th step over 1000
    periods of the undamped spring released from rest."""
    case, p, scene = _case("stiff_spring")
    w0, e0 = case.omega(p), case.energy_scale(p)
    sim = ENGINE.build(scene, y / w0, integrator)
    steps = math.ceil(STABILITY_PERIODS * 2 * math.pi / y)
    for _ in range(0, steps, 100):
        sim.step(100)
        o = {k: np.asarray([v]) for k, v in sim.observe().items()}
        energy = case.energy(p, o)[0]
        if sim.failure or not np.isfinite(energy) or energy > ENERGY_BOUND * e0:
            return False
    return True


@pytest.mark.parametrize("integrator,theory", [
    ("symplectic_euler", 2.0), ("implicit", 2.0), ("implicitfast", 2.0),
    ("rk4", 2.0 * math.sqrt(2.0)),
])
def test_measured_stability_limit_matches_theory(integrator, theory):
    limit = bisect_limit(lambda y: _stable(integrator, y), 1.0, 4.0, tol=1e-4)
    assert limit == pytest.approx(theory, rel=0.01)


@pytest.mark.parametrize("y", [0.5, 2.5, 10.0, 1e3])
def test_discrete_never_diverges_but_damps(y):
    """discrete is backward Euler on a spring: stable at any y, energy x 1/(1+y^2) per step."""
    case, p, scene = _case("stiff_spring")
    sim = ENGINE.build(scene, y / case.omega(p), "discrete")
    steps = max(1, math.ceil(20 * 2 * math.pi / y))  # 20 periods
    sim.step(steps)
    o = {k: np.asarray([v]) for k, v in sim.observe().items()}
    ratio = math.sqrt(case.energy(p, o)[0] / case.energy_scale(p))
    assert sim.failure is None
    # absolute part: u = x - L0 is read from x near 1.1 m, so ~1e-16 m of it is round-off
    assert ratio == pytest.approx((1 + y * y) ** (-steps / 2), rel=1e-6, abs=1e-12)
    assert ratio < 1e-2


def test_discrete_damps_even_at_the_reference_dt():
    case, p, scene = _case("stiff_spring")
    y = case.omega(p) * case.reference_dt(p)
    sim = ENGINE.build(scene, case.reference_dt(p), "discrete")
    steps = math.ceil(20 * 2 * math.pi / y)
    sim.step(steps)
    o = {k: np.asarray([v]) for k, v in sim.observe().items()}
    ratio = math.sqrt(case.energy(p, o)[0] / case.energy_scale(p))
    assert ratio == pytest.approx((1 + y * y) ** (-steps / 2), rel=1e-9)
    assert ratio < 0.05  # 20 periods at w0 dt = 0.05 keep 4 % of the amplitude


# ---------------------------------------------------------------------------------------------
# 4. Full runs at each case's reference dt
# ---------------------------------------------------------------------------------------------
# the particle, spring and rod cases; spheres have their own file, and MuJoCo has no fluid
@pytest.mark.parametrize("name", ["free_fall", "stiff_spring", "pendulum"])
@pytest.mark.parametrize("integrator", list(METHODS))
def test_reference_dt_runs_are_ok_and_within_tolerance(name, integrator):
    case = get_case(name)
    for variant in case.variants:
        p = case.variant_params(variant)
        row = run_job(Job(name, variant, "mujoco", "", integrator, case.reference_dt(p)),
                      repeats=1, budget_s=0.0)
        assert row["status"] == "ok", (variant, row["reason"])
        assert row["us_per_step"] > 0 and row["compile_s"] > 0
        if method_info(integrator) is None:  # MuJoCo's own scheme: only the target question
            assert row["consistency"] == "no method reference"
            if integrator in ("implicit", "implicitfast"):
                # semi-implicit Euler with velocity-dependent forces implicit: symplectic Euler
                # exactly where nothing depends on velocity (measured 1.00 x its exact discrete
                # error), less error with damping (0.23-0.76 x): never above its bound
                settings = {**json.loads(row["settings"]),
                            "integrator": method_info("symplectic_euler")}
                bound, _ = case.tolerance(p, "symplectic_euler", 1.0, row["dt"], "", settings)
                assert row["err_max"] <= bound, (variant, row["err_max"], bound)
            continue
        # a bound not below half the motion gives no verdict (unresolved): then the error
        # must still stay under that bound
        assert (row["consistency"] == "consistent") or (
            row["consistency"] == "unresolved" and row["err_max"] <= row["tolerance"]), \
            (variant, row["err_max"], row["tolerance"])


# ---------------------------------------------------------------------------------------------
# 5. Settings, divergence, silent reset, the log file, bad input
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("integrator", list(METHODS))
def test_settings_report_every_engine_notes_fix(integrator):
    case, p, scene = _case("free_fall", "drag")
    sim = ENGINE.build(scene, 1e-3, integrator)
    s = json.loads(json.dumps(sim.settings()))
    described = s["integrator"]
    assert described["name"] == integrator
    for key in ("order", "family", "explicit", "symplectic", "native"):
        assert key in described
    assert described["native"] == METHODS[integrator].native
    assert s["dtype"] == "float64" and s["threads"] == 1
    for key in ("gravity", "timestep", "eulerdamp", "autoreset", "warnings", "contacts",
                "inertia", "drag", "step_call"):
        assert key in s
    assert "disabled" in s["eulerdamp"] and "disabled" in s["autoreset"]
    # and the compiled model really is that model
    m, flags = sim.model, mujoco.mjtDisableBit
    assert m.opt.timestep == 1e-3
    np.testing.assert_array_equal(m.opt.gravity, scene.gravity)
    for flag in (flags.mjDSBL_EULERDAMP, flags.mjDSBL_AUTORESET, flags.mjDSBL_CONTACT):
        assert m.opt.disableflags & int(flag)
    assert m.ngeom == 0
    np.testing.assert_array_equal(m.body_inertia[1], [POINT_INERTIA] * 3)
    np.testing.assert_array_equal(m.dof_damping, [p["drag"]] * 3)
    assert m.opt.integrator == int(getattr(mujoco.mjtIntegrator, METHODS[integrator].native))


def test_explicit_instability_is_reported_as_diverged(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    case = get_case("stiff_spring")
    p = case.variant_params("default")
    row = run_job(Job("stiff_spring", "default", "mujoco", "", "symplectic_euler",
                      2.5 / case.omega(p)), repeats=1, budget_s=0.0)
    assert row["status"] == "diverged", row["reason"]
    assert os.listdir(tmp_path) == []  # no MUJOCO_LOG.TXT


def test_engine_breakdown_sets_failure_and_restores_warning_handler(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    before = mujoco.get_mju_user_warning()
    case, p, scene = _case("stiff_spring")
    sim = ENGINE.build(scene, 3.0 / case.omega(p), "symplectic_euler")
    sim.step(2000)
    assert sim.failure and "mjWARN_BADQ" in sim.failure
    assert mujoco.get_mju_user_warning() is before
    assert os.listdir(tmp_path) == []


def test_silent_reset_is_reported(tmp_path, monkeypatch):
    """With MuJoCo's auto-reset left on (its default), a blow-up is silently replaced by the
    initial pose; the warning counters still give it away."""
    monkeypatch.chdir(tmp_path)
    case, p, scene = _case("stiff_spring")
    sim = ENGINE.build(scene, 3.0 / case.omega(p), "symplectic_euler")
    sim.model.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
    sim.step(2000)
    o = sim.observe()
    assert np.all(np.isfinite(o["x"])) and np.all(np.abs(o["x"]) < 10)  # looks harmless
    assert sim.failure and "mjWARN_BADQ" in sim.failure  # the runner's cue for "diverged"
    assert os.listdir(tmp_path) == []


def test_unsupported_scenes_give_specific_reasons():
    ball = Body(mass=1.0, position=(1.0, 0.0, 0.0))
    other = Body(mass=1.0, position=(2.0, 0.0, 0.0))
    pair = Scene(parts=(Particles.of((ball, other)),
                        Springs.of((Spring(body=0, other=1, stiffness=1.0, rest_length=1.0),))))
    assert "two bodies" in ENGINE.supports(pair)
    off_line = Scene(parts=(Particles.of((ball,)),
                            Springs.of((Spring(body=0, stiffness=1.0, rest_length=1.0),))),
                     gravity=(0.0, 0.0, -9.81))
    assert "along the anchor-body line" in ENGINE.supports(off_line)
    through = Scene(parts=(Particles.of((Body(mass=1.0, position=(3.0, 0.0, 0.0)),)),
                           Springs.of((Spring(body=0, stiffness=1.0, rest_length=1.0),))))
    assert "through its anchor" in ENGINE.supports(through)
    bad_rod = Scene(parts=(Particles.of((ball,)),
                           Joints.of((Joint(body=0, anchor=(0, 0, 0), length=2.0),))),
                    gravity=(0.0, 0.0, -9.81))
    assert "distance L" in ENGINE.supports(bad_rod)
    flat = Scene(parts=(Particles.of((ball,)),), dim=2)
    assert "3D only" in ENGINE.supports(flat)
    assert "offers no integrator" in ENGINE.supports(Scene(parts=(Particles.of((ball,)),)),
                                                 "velocity_verlet")


def test_bad_input_raises_value_error():
    _, _, scene = _case("free_fall")
    with pytest.raises(ValueError, match="integrator"):
        ENGINE.build(scene, 1e-3, "euler")
    with pytest.raises(ValueError, match="dt"):
        ENGINE.build(scene, 0.0, "rk4")
    with pytest.raises(ValueError, match="formulation"):
        ENGINE.build(scene, 1e-3, "rk4", "generalized")


def test_engine_reports_its_name_package_version_and_integrators():
    assert ENGINE.name == "mujoco" and ENGINE.package == "mujoco"
    assert ENGINE.available() and ENGINE.version() == mujoco.__version__
    assert set(ENGINE.integrators) == {"symplectic_euler", "rk4", "implicit", "implicitfast",
                                       "discrete"}
