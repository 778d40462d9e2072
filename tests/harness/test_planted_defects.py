"""Planted-defect engines (adapters/planted_defects): the control engine equals refsim bit for
bit, each defect changes what it says and only that, and the verdicts catch a quick subset."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from refsim_adapters.planted_defects import driver
from refsim_adapters.planted_defects.engines import (
    DEFECTS,
    KUTTA3,
    UNREACHABLE,
    VELOCITY_KEEP,
    as_float32,
    register_all,
)
from refsim.integrators import EULER, HEUN, ExplicitRK
from refsim.run.job import Job, run_job
from refsim.registry import get_case, get_engine, unregister
from refsim.scene import Joints, RigidBodies, SpringNetwork, Springs
from refsim.scene.gravity_pairs import GravityPairs
from refsim.scene.pivots import RigidPivots, check_on_anchor


@pytest.fixture(scope="module", autouse=True)
def planted():
    names = register_all()
    yield
    for name in names:
        unregister("engine", name)


def _scene(case, variant):
    c = get_case(case)
    return c.scene(c.variant_params(variant, {}))


def _ref_dt(case, variant):
    c = get_case(case)
    return c.reference_dt(c.variant_params(variant, {}))


def _sims(defect, case, variant, integrator, engine_variant=""):
    """(refsim's sim, the planted engine's sim) on the case's scene at its reference dt."""
    scene, dt = _scene(case, variant), _ref_dt(case, variant)
    return (get_engine("refsim").build(scene, dt, integrator, engine_variant),
            get_engine(DEFECTS[defect].engine).build(scene, dt, integrator, engine_variant))


# -- the control engine -------------------------------------------------------------------------
CONTROL_JOBS = [("stiff_spring", "underdamped", "", "rk4"),
                ("pendulum", "default", "generalized", "velocity_verlet"),
                ("pendulum", "default", "kkt", "rk4"),
                ("sphere_pairs", "head_on", "discrete", "symplectic_euler"),
                ("gradient_descent", "default", "", "midpoint")]


@pytest.mark.parametrize("case,variant,engine_variant,integrator", CONTROL_JOBS)
def test_control_equals_refsim_bit_for_bit(case, variant, engine_variant, integrator):
    c = get_case(case)
    dt = max(c.dts(c.variant_params(variant, {})))  # the sweep's coarsest: the fewest steps
    rows = [run_job(Job(case, variant, engine, engine_variant, integrator, dt), repeats=0,
                    keep_trajectory=True) for engine in ("refsim", "planted_control")]
    ref, ctl = rows
    assert ref["status"] == ctl["status"] == "ok"
    assert set(ref["trajectory"]) == set(ctl["trajectory"])
    for name, values in ref["trajectory"].items():
        # same operations: the control engine runs refsim's own code
        assert np.array_equal(values, ctl["trajectory"][name]), name
    for col in ("err_max", "err_final", "energy_drift", "settings"):
        assert ref[col] == ctl[col] or (ref[col] != ref[col] and ctl[col] != ctl[col]), col


def test_control_steps_a_rigid_body_as_refsim_bit_for_bit():
    # at the sim level: the case's reference (a 4 s elliptic solve) is not the point here
    ref, sim = _sims("control", "compound_pendulum", "default", "rk4", "quat_exp")
    for n in (1, 7, 100):
        ref.step(n), sim.step(n)
        o, r = sim.observe(), ref.observe()
        # same operations: the control engine runs refsim's own code
        assert set(o) == set(r) and all(np.array_equal(o[k], r[k]) for k in r)
    assert sim.settings() == ref.settings()


# -- each defect changes what it says -------------------------------------------------------------
def test_scene_defects_change_one_field():
    scene = _scene("free_fall", "default")
    assert DEFECTS["gravity_plus_0.1pct"].scene(scene).gravity == tuple(
        1.001 * g for g in scene.gravity)
    kepler = DEFECTS["gravity_plus_0.1pct"].scene(_scene("kepler", "e0.5"))
    assert kepler.part(GravityPairs).G == 1.001 * _scene("kepler", "e0.5").part(GravityPairs).G
    spring = _scene("stiff_spring", "underdamped")
    (old,) = spring.part(Springs).to_records()

    def one_spring(defect):
        (s,) = DEFECTS[defect].scene(spring).part(Springs).to_records()
        return s
    assert one_spring("stiffness_plus_1pct") == replace(old, stiffness=old.stiffness * 1.01)
    assert old.damping > 0 and one_spring("no_spring_damping") == replace(old, damping=0.0)
    assert one_spring("rest_length_plus_0.5pct") == replace(old,
                                                            rest_length=old.rest_length * 1.005)
    pendulum = _scene("pendulum", "default")
    (rod,) = pendulum.part(Joints).to_records()
    (j,) = DEFECTS["rest_length_plus_0.5pct"].scene(pendulum).part(Joints).to_records()
    assert j == replace(rod, length=rod.length * 1.005)
    cloth = _scene("cloth_hang", "bending")
    before = cloth.part(SpringNetwork)
    net = DEFECTS["stiffness_plus_1pct"].scene(cloth).part(SpringNetwork)
    # same operations: the defect's one product (IEEE products commute exactly)
    assert np.array_equal(net.stiffness, before.stiffness * 1.01)
    assert np.array_equal(net.dihedral_stiffness, before.dihedral_stiffness * 1.01)
    assert np.array_equal(net.rest_length, before.rest_length)
    # a scene the defect cannot touch is returned as it is (the driver skips its jobs)
    assert DEFECTS["no_spring_damping"].scene(scene) is scene


def test_longer_pivot_arm_keeps_the_body_on_its_pivot():
    scene = _scene("compound_pendulum", "default")
    old = scene.part(RigidPivots)
    new = DEFECTS["rest_length_plus_0.5pct"].scene(scene).part(RigidPivots)
    # same operations: the defect's one product (IEEE products commute exactly)
    assert np.array_equal(new.body_point, old.body_point * 1.005)
    assert not np.array_equal(new.anchor, old.anchor)
    check_on_anchor(new, scene.part(RigidBodies))  # the body still starts on its (moved) pivot
    ref, sim = _sims("rest_length_plus_0.5pct", "compound_pendulum", "default", "rk4",
                     "quat_exp")
    assert np.allclose(ref.observe()["x"], sim.observe()["x"], rtol=0, atol=1e-12)


@pytest.mark.parametrize("defect,integrator,tableau", [("heun_as_rk4", "rk4", HEUN),
                                                      ("rk3_as_rk4", "rk4", KUTTA3),
                                                      ("euler_as_verlet", "velocity_verlet",
                                                       EULER)])
def test_integrator_defects_run_another_tableau_under_the_claimed_name(defect, integrator,
                                                                      tableau):
    for case, engine_variant in (("stiff_spring", ""), ("pendulum", "generalized"),
                                 ("advection_vortex", ""), ("compound_pendulum", "quat_exp")):
        if get_engine("refsim").supports(_scene(case, "default"), integrator) is not None:
            continue
        ref, sim = _sims(defect, case, "default", integrator, engine_variant)
        assert sim.inner.stepper.tableau.a == tableau.a
        assert sim.inner.stepper.tableau.b == tableau.b
        assert sim.settings()["integrator"] == ref.settings()["integrator"]  # reported as named
    # other integrators are left alone
    ref, sim = _sims(defect, "stiff_spring", "default", "midpoint")
    sim.step(10), ref.step(10)
    # same operations: midpoint is left alone, the defect engine runs refsim's own code
    assert np.array_equal(sim.observe()["x"], ref.observe()["x"])


def test_kutta3_is_a_third_order_tableau():
    a, b, c = (np.array(m, float) for m in (KUTTA3.a, KUTTA3.b, KUTTA3.c))
    assert np.allclose([b.sum(), b @ c, b @ c ** 2, b @ a @ c], [1, 1 / 2, 1 / 3, 1 / 6])
    assert not np.isclose(b @ a @ a @ c, 1 / 24)  # not fourth order (three stages)
    assert isinstance(_sims("rk3_as_rk4", "stiff_spring", "default", "rk4")[1].inner.stepper,
                      ExplicitRK)


def test_time_off_by_one_reports_the_state_after_one_step_at_t0():
    ref, sim = _sims("time_off_by_one", "pendulum", "default", "velocity_verlet", "generalized")
    ref.step(1)
    o, r = sim.observe(), ref.observe()
    assert o["t"] == 0.0 and r["t"] == ref.dt
    # same operations: the same first step, reported one step late
    assert np.array_equal(o["x"], r["x"]) and np.array_equal(o["v"], r["v"])


def test_velocity_damping_scales_v_after_every_step():
    ref, sim = _sims("velocity_damping", "stiff_spring", "default", "symplectic_euler")
    ref.step(1)
    sim.step(1)
    assert np.array_equal(sim.observe()["x"], ref.observe()["x"])
    # same operations: the same step, then the defect's one product v * VELOCITY_KEEP
    assert np.array_equal(sim.observe()["v"], ref.observe()["v"] * VELOCITY_KEEP)
    sim.step(3)  # step(n) is n single steps, each damped
    assert sim.steps == 4 and sim.inner.steps == 4


def test_float32_state_rounds_after_every_step():
    ref, sim = _sims("float32_state", "sphere_pairs", "head_on", "symplectic_euler",
                     "discrete")
    sim.step(5), ref.step(5)
    o, r = sim.observe(), ref.observe()
    for name in ("x", "v"):
        # exact: rounding a float32-representable double to float32 changes nothing
        assert np.array_equal(o[name], as_float32(o[name]))
        assert np.allclose(o[name], r[name], rtol=1e-6, atol=1e-6)
        assert not np.array_equal(o[name], r[name]) or np.array_equal(r[name],
                                                                       as_float32(r[name]))


def test_a_defect_with_nothing_to_change_is_unreachable_never_matters():
    dt = _ref_dt("gradient_descent", "default")
    row = run_job(Job("gradient_descent", "default", "planted_velocity_damping", "",
                      "midpoint", dt), repeats=0)
    assert row["status"] == "failed" and UNREACHABLE in row["reason"]
    assert not driver.matters(row, {**row, "status": "ok"})


# -- the verdicts catch a quick subset -------------------------------------------------------------
QUICK = [("heun_as_rk4", "stiff_spring", "default", "", "rk4"),
         ("gravity_plus_0.1pct", "free_fall", "default", "", "velocity_verlet"),
         ("time_off_by_one", "pendulum", "default", "generalized", "velocity_verlet")]


def test_verdicts_catch_a_quick_subset():
    jobs = []
    for defect, case, variant, engine_variant, integrator in QUICK:
        job = Job(case, variant, "", engine_variant, integrator, _ref_dt(case, variant))
        jobs += [replace(job, engine=DEFECTS[defect].engine),
                 replace(job, engine="planted_control")]
    table = driver.run_jobs(jobs, workers=1)
    rows = table.to_dict("records")
    for k, (defect, case, *_rest) in enumerate(QUICK):
        d, c = rows[2 * k], rows[2 * k + 1]
        assert driver.matters(d, c), (defect, case)
        assert driver.caught([d], [c]), (defect, case, d["consistency_reason"])
        assert not driver.caught([c], [c]), (defect, case)


def test_energy_behaviour_catches_damping_where_the_error_bound_does_not():
    """pendulum, generalized coordinates, velocity Verlet at dt = 0.05 s (200 steps): the
    1e-4 per step velocity damping keeps the error inside the method's bound, but the energy
    drifts, which a symplectic method's energy never does; the control's stays bounded."""
    job = Job("pendulum", "default", "", "generalized", "velocity_verlet", 0.05)
    table = driver.run_jobs([replace(job, engine=DEFECTS["velocity_damping"].engine),
                             replace(job, engine="planted_control")], workers=1)
    d, c = table.to_dict("records")
    assert d["err_max"] <= d["tolerance"]  # the error bound alone lets it through
    assert d["consistency"] == "inconsistent" and "energy error grew" in \
        d["consistency_reason"]
    assert c["consistency"] == "consistent", c["consistency_reason"]
