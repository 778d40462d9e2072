"""taichi adapter on sphere contacts: outcomes found overlapped, the overlap-normal variant,
angular momentum, Newton's cradle, the box, the broad phase, friction, gravity, determinism,
settings. The exact outcomes of every pair variant (head-on on every impulse engine, oblique on
taichi by its time-of-impact normal) and momentum in pair collisions, checked with the other
engines, are in tests/conformance/test_conformance_spheres.py; the cases in
tests/conformance/sphere_cases.py.

taichi (1.7.4) must be installed: a missing engine fails at import, never skips. The contact
kernel is the adapter's own (kick-drift, grid broad phase, time-of-impact normal, Gauss-Seidel
Newton impulses with Guendelman stick/slide friction, positional projection).
"""
from __future__ import annotations

import json

import numpy as np
import pytest
import sphere_cases
from sphere_cases import params

from refsim.registry import get_engine
from refsim_adapters.taichi_engine.runtime import import_taichi
from refsim.scene import Body, ContactModel, Joint, Joints, Particles, Scene, Wall, Walls

SE = "symplectic_euler"
TAICHI = get_engine("taichi")
import_taichi()  # CI must have every engine: fail here, not skip


def _run(variant, dt=1e-3, engine_variant="", **over):
    """The accuracy row with its trajectory (cached per process, shared with the conformance
    tests: rows are read, never changed)."""
    return sphere_cases.row("taichi", variant, SE, dt, engine_variant, **over)


def _sim(variant, dt=1e-3, engine_variant="", **over):
    c, p = params(variant, **over)
    return TAICHI.build(c.scene(p), dt, SE, engine_variant)


# 1. post-collision velocities (exact on every pair variant at any dt, by the time of impact's
#    normal: tests/conformance/test_conformance_spheres.py, test_pair_outcome_is_exact) -------
@pytest.mark.parametrize("variant", ["head_on_1to3_e0.5", "oblique"])
def test_outcome_exact_when_found_overlapped(variant):
    """At dt = 7e-4 the pair is found overlapped (by up to v_rel dt = 1.4e-3 m): the normal
    is backed up to the touching pose, so the outcome stays exact; projection then removes
    the overlap (none left at the samples), and positions are off by about the overlap."""
    c, p = params(variant)
    sim = TAICHI.build(c.scene(p), 7e-4, SE)
    sim.step(1000)
    stats = sim.contact_stats()
    assert 1e-4 < stats["depth_max"] <= 2 * p["speed"] * 7e-4
    assert stats["impulses"] == 1
    v_ref, _ = c.outcome(p)
    assert np.abs(sim.observe()["v"] - v_ref).max() <= 1e-14
    row = _run(variant, 7e-4)
    assert row["penetration_max"] < 1e-15 and 1e-4 < row["position_err"] < 1e-3


@pytest.mark.parametrize("variant, dt, err", [
    ("oblique", 4e-3, 3.765e-2), ("oblique", 1e-3, 8.566e-3), ("oblique", 5e-4, 1.451e-3),
    ("oblique_friction", 1e-3, 6.812e-3)])
def test_overlap_normal_variant_misses_by_the_detection_tilt(variant, dt, err):
    """The engine variant `overlap_normal` takes the centre line of the pose found
    overlapped (what most engines do): the normal tilts by up to v_rel dt / (2 r). Measured
    errors (m/s, asserted to 1 %; the same as pymunk's, which applies the same law at the
    same detected pose) sit within the case's discrete-detection bound; head-on is exact."""
    row = _run(variant, dt, "overlap_normal")
    assert row["status"] == "ok" and (row["consistency"] == "consistent")
    assert json.loads(row["settings"])["detection"] == "discrete"
    assert row["err_max"] == pytest.approx(err, rel=0.01)
    head_on = _run("head_on_1to3_e0.5", dt, "overlap_normal")
    assert (head_on["consistency"] == "consistent") and head_on["err_max"] <= 1e-14


# 2. momentum (in pair collisions: tests/conformance/test_conformance_spheres.py) ---------------
@pytest.mark.parametrize("variant, dt, measured", [
    ("oblique_friction", 1e-3, 5.246e-4), ("oblique", 7e-4, 2.628e-4),
    ("oblique", 4e-3, 2.314e-3)])
def test_angular_momentum_departs_by_the_overlap(variant, dt, measured):
    """What does not hold exactly: angular momentum about the origin. The impulse acts on the
    pose found overlapped (the two contact points differ by the relative drift since
    touching) and projection moves the centres by the overlap delta without touching the
    velocities; both change L by O(m_red delta |v_rel|). Measured (kg m^2/s, to 1 %) about
    half of m_red delta_max |v_rel'|, asserted below it; head-on keeps it exactly."""
    c, p = params(variant)
    m = np.array([p["mass"], p["mass"] * p["ratio"]])
    inertia = 0.4 * m * p["radius"] ** 2
    sim = TAICHI.build(c.scene(p), dt, SE)

    def ang(o):
        return m @ np.cross(o["x"], o["v"]) + inertia @ o["w"]
    first = ang(sim.observe())
    sim.step(int(round(p["duration"] / dt)))
    o = sim.observe()
    change = np.linalg.norm(ang(o) - first)
    bound = m[0] * m[1] / m.sum() * sim.contact_stats()["depth_max"] * np.linalg.norm(
        o["v"][1] - o["v"][0])
    assert change == pytest.approx(measured, rel=0.01) and change < bound


# 3. Newton's cradle ----------------------------------------------------------------------------
@pytest.mark.parametrize("dt", [4e-3, 1e-3, 7e-4])
@pytest.mark.parametrize("engine_variant", ["", "overlap_normal"])
def test_cradle_reaches_the_ideal_outcome(dt, engine_variant):
    """Measured outcome: (0, 0, 0, 0, v) exactly, the ideal one. Gauss-Seidel pair impulses in
    contact order are a sequence of binary elastic impacts, each one exchanging the
    velocities: the striker's impact, then (1,2), (2,3), (3,4) within the same pass (the
    resting balls touch, gap <= slop, so they are contacts from the start), and a second
    pass finds nothing approaching. A simultaneous (Jacobi) treatment would depart."""
    c, p = params("cradle")
    row = _run("cradle", dt, engine_variant)
    assert row["status"] == "ok" and (row["consistency"] == "consistent") and row["err_max"] == 0.0
    v_final = row["trajectory"]["v"][-1]
    # exact: equal unit masses, e = 1: every impulse is binary-exact arithmetic
    assert v_final[:, 0].tolist() == [0.0, 0.0, 0.0, 0.0, p["speed"]]
    assert np.abs(v_final[:, 1:]).max() == 0.0
    assert row["momentum_drift"] == 0.0 and row["energy_drift"] == 0.0
    sim = TAICHI.build(c.scene(p), dt, SE, engine_variant)
    sim.step(int(round(p["duration"] / dt)))
    stats = sim.contact_stats()
    assert stats["impulses"] == 4 and stats["max_passes"] == 2
    assert stats["steps_at_pass_cap"] == 0


# 4. the box ------------------------------------------------------------------------------------
def test_box_100_conserves_energy_and_momentum_over_1e4_steps():
    """e = 1, mu = 0: every impulse is a binary elastic impact, energy-conserving on its own,
    so Gauss-Seidel keeps the kinetic energy to round-off: measured drift 1.9e-15 over
    10^4 steps (bound 1e-13, the case allows 1e-6). Momentum balances the walls' impulse
    to 1.2e-16. Overlaps found at detection reach 2.5e-3 m (v dt with v up to ~3 m/s); the
    samples, taken after projection, show none (penetration_max ~1e-17 m)."""
    row = _run("box_100", duration=10.0)
    assert row["status"] == "ok" and (row["consistency"] == "consistent") and row["steps"] == 10_000
    assert row["err_max"] < 1e-13 and row["energy_drift"] < 1e-13
    assert row["momentum_drift"] < 1e-14
    assert row["penetration_max"] < 1e-12
    sim = _sim("box_100", duration=10.0)
    sim.step(10_000)
    stats = sim.contact_stats()
    assert stats["impulses"] > 1000 and stats["steps_at_pass_cap"] == 0
    assert 1e-4 < stats["depth_max"] < 3 * 3e-3


def test_box_1000_short_run_conserves_energy_and_momentum():
    row = _run("box_1000", duration=0.3)
    assert row["status"] == "ok" and (row["consistency"] == "consistent") and row["energy_drift"] < 1e-13
    assert row["momentum_drift"] < 1e-14 and row["penetration_max"] < 1e-12


def test_runs_are_bit_identical_and_launch_per_step_agrees():
    """Everything inside the serialised time loop runs serially (contact order fixed, no
    atomics race): repeated runs and one launch per step give the same bits."""
    def trajectory(engine_variant):
        sim = _sim("box_100", engine_variant=engine_variant)
        out = []
        for _ in range(4):
            sim.step(50)
            o = sim.observe()
            out.append(np.concatenate([o["x"].ravel(), o["v"].ravel(), o["w"].ravel(),
                                       o["wall_impulse"]]))
        return np.array(out)
    first = trajectory("")
    # same operations: serial time loop, fixed contact order, no atomics, fast_math off
    assert np.array_equal(first, trajectory(""))
    assert np.array_equal(first, trajectory("launch_per_step"))


# broad phase -----------------------------------------------------------------------------------
def _contacts_found(x, r):
    scene = Scene(parts=(Particles.of(tuple(Body(1.0, xi, radius=r, inertia=0.4 * r * r)
                                            for xi in x)),),
                  contact=ContactModel(restitution=1.0))
    sim = TAICHI.build(scene, 1e-3, SE)
    sim.step(1)  # nothing moves; contacts are counted before projection
    return sim.contact_stats()["contacts"]


@pytest.mark.parametrize("spread", ["uniform", "clusters"])
def test_grid_finds_every_touching_pair_once(spread, rng=np.random.default_rng(3)):
    """The half-stencil grid against a k-d tree: the same number of pairs within
    (r_a + r_b)(1 + slop). `clusters` spans 200 m, so the cell size grows past 2 r to fit
    the grid arrays (8 N + 64 cells)."""
    from scipy.spatial import cKDTree
    r = 0.05
    if spread == "uniform":
        x = rng.uniform(0.0, 3.0, (2000, 3))
    else:
        centres = rng.uniform(0.0, 200.0, (8, 3))
        x = centres[rng.integers(0, 8, 1000)] + rng.uniform(0.0, 1.0, (1000, 3))
    truth = len(cKDTree(x).query_pairs(2 * r * (1 + 1e-9)))
    assert truth > 100
    assert _contacts_found(x, r) == truth


def test_contact_list_overflow_is_a_failure():
    """50 spheres piled within one radius make 1225 pairs, more than the 16 N + 64 = 864
    the list holds: the sim reports it instead of dropping contacts silently."""
    x = np.random.default_rng(0).uniform(0.0, 0.01, (50, 3))
    scene = Scene(parts=(Particles.of(tuple(Body(1.0, xi, radius=0.1, inertia=0.004)
                                            for xi in x)),),
                  contact=ContactModel())
    sim = TAICHI.build(scene, 1e-3, SE)
    sim.step(1)
    assert sim.failure and "contact list full" in sim.failure


def test_non_finite_positions_skip_contacts_and_are_reported():
    """A sphere overflowing to inf: no grid is built from it (no out-of-range cell index),
    the sim names the failure and the runner's check sees the non-finite state."""
    scene = Scene(parts=(Particles.of((
        Body(1.0, (0.0, 0.0, 0.0), (1e308, 0.0, 0.0), radius=0.1, inertia=0.004),
        Body(1.0, (1.0, 0.0, 0.0), radius=0.1, inertia=0.004))),), contact=ContactModel())
    sim = TAICHI.build(scene, 1.0, SE)
    sim.step(3)
    assert sim.failure and "non-finite" in sim.failure
    assert not np.all(np.isfinite(sim.observe()["x"]))


# friction, walls, gravity ----------------------------------------------------------------------
@pytest.mark.parametrize("mu, regime", [(0.05, "slide"), (0.3, "stick"), (1.0, "stick")])
def test_friction_stick_and_slide_match_the_exact_impact(mu, regime):
    """Oblique impact with spin 20 rad/s: sticks when the impulse stopping the slip (3/7
    N s here) is within mu J_n, else slides with mu J_n. The case's exact outcome
    (velocities and spins) to round-off in both regimes."""
    c, p = params("oblique_friction", friction=mu)
    row = _run("oblique_friction", friction=mu)
    assert (row["consistency"] == "consistent") and row["err_max"] <= 1e-14
    _, w_ref = c.outcome(p)
    assert np.abs(row["trajectory"]["w"][-1] - w_ref).max() <= 1e-13
    x0, v0, m, w0 = c.initial_state(p)
    n = np.array([np.sqrt(4 * p["radius"] ** 2 - p["impact"] ** 2), 0.0, p["impact"]]) / (
        2 * p["radius"])
    arm = p["radius"] * n
    slip = (v0[1] - np.cross(w0[1], arm)) - (v0[0] + np.cross(w0[0], arm))
    jn = -2 * (slip @ n) / (2 / m[0])
    stick = np.linalg.norm(slip - (slip @ n) * n) / (2 / m[0] + 2 * 2.5 / m[0])
    assert (stick <= mu * jn) == (regime == "stick")


def _wall_impact(v, w, m, r, e, mu, n):
    """A sphere's impact on a fixed plane with normal n (into free space): Newton along n,
    Coulomb stick/slide on the slip of the contact point x - r n. Independent closed form."""
    inertia = 0.4 * m * r * r
    slip = v + np.cross(w, -r * n)
    jn = -(1 + e) * (slip @ n) * m
    tangential = slip - (slip @ n) * n
    k_t = 1 / m + r * r / inertia
    size = min(np.linalg.norm(tangential) / k_t, mu * jn)
    impulse = jn * n - size * tangential / max(np.linalg.norm(tangential), 1e-300)
    return v + impulse / m, w + np.cross(-r * n, impulse) / inertia, impulse


@pytest.mark.parametrize("mu", [0.0, 0.1, 0.6])
def test_wall_impact_with_spin_and_the_wall_impulse(mu):
    """A spinning sphere hits the floor obliquely (no gravity): velocity, spin and the
    recorded wall impulse equal the closed form (0.1: slides, 0.6: sticks)."""
    m, r, e = 2.0, 0.1, 0.7
    v0, w0 = np.array([1.0, 0.5, -2.0]), np.array([3.0, -10.0, 1.0])
    n = np.array([0.0, 0.0, 1.0])
    scene = Scene(parts=(Particles.of((Body(m, (0.0, 0.0, 0.5), v0, radius=r,
                                            inertia=0.4 * m * r * r, angular_velocity=w0),)),
                         Walls.of((Wall((0.0, 0.0, 0.0), n),))), contact=ContactModel(e, mu))
    sim = TAICHI.build(scene, 7e-4, SE)
    sim.step(400)
    o = sim.observe()
    v1, w1, impulse = _wall_impact(v0, w0, m, r, e, mu, n)
    assert np.abs(o["v"][0] - v1).max() <= 1e-14 and np.abs(o["w"][0] - w1).max() <= 1e-13
    assert np.abs(o["wall_impulse"] - impulse).max() <= 1e-14
    assert sim.contact_stats()["impulses"] == 1


def test_gravity_is_honoured_and_balances_with_the_wall_impulse():
    """A ball dropped on the floor under gravity (e = 0.8): free flight is the kick-drift
    sequence z_k = z0 - k(k+1)/2 dt^2 g until the bounce, and at every sample
    m (v - v0) = J_walls + m g t to round-off."""
    m, r, g, dt = 1.5, 0.1, 9.81, 1e-3
    scene = Scene(parts=(Particles.of((Body(m, (0.0, 0.0, 1.0), radius=r,
                                            inertia=0.4 * m * r * r),)),
                         Walls.of((Wall((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),))),
                  gravity=(0.0, 0.0, -g), contact=ContactModel(restitution=0.8))
    sim = TAICHI.build(scene, dt, SE)
    sim.step(100)
    assert sim.observe()["x"][0, 2] == pytest.approx(1.0 - 100 * 101 / 2 * dt * dt * g,
                                                    abs=1e-14)
    for _ in range(30):
        sim.step(50)
        o = sim.observe()
        balance = m * o["v"][0] - o["wall_impulse"] - m * np.array([0.0, 0.0, -g]) * o["t"]
        assert np.abs(balance).max() < 1e-12
    assert o["wall_impulse"][2] > 0 and sim.contact_stats()["impulses"] >= 2


# 5. settings and the contract ------------------------------------------------------------------
def test_settings_report_contact_model_and_restitution_mapping():
    s = json.loads(json.dumps(_sim("oblique_friction").settings()))
    assert s["contact_model"] == "impulse"
    assert s["restitution"] == 1.0 and "(1 + e)" in s["restitution_mapping"]
    assert "no per-body product" in s["restitution_mapping"]
    assert s["friction"] == 0.3 and "Guendelman" in s["friction_model"]
    assert s["detection"] == "discrete_toi_normal" and "time of impact" in s["contact_normal"]
    assert s["solver"]["max_passes"] == s["solver_iterations"] == 100
    assert "Gauss-Seidel" in s["solver"]["kind"] and "none" in s["ccd"]
    assert "never recomputed" in s["inertia"]
    assert s["integrator"]["name"] == SE and s["dtype"] == "float64" and s["threads"] == 1
    assert s["default_fp"] == "f64" and "serialize=True" in s["time_loop"]
    assert s["step_order"].startswith("kick")
    c, p = params("head_on")
    assert TAICHI.formulations(c.scene(p)) == ("", "launch_per_step", "overlap_normal")


def test_observe_gives_per_sphere_shapes_and_the_initial_spin():
    o = _sim("oblique_friction").observe()
    assert o["t"] == 0.0 and o["x"].shape == o["v"].shape == o["w"].shape == (2, 3)
    assert o["w"][0].tolist() == [0.0, 20.0, 0.0] and o["wall_impulse"].shape == (3,)


def test_refusals_name_the_reason():
    c, p = params("head_on")
    scene = c.scene(p)
    assert "symplectic_euler only" in TAICHI.supports(scene, "rk4")
    with pytest.raises(ValueError, match="symplectic_euler only"):
        TAICHI.build(scene, 1e-3, "velocity_verlet")
    point = Scene(parts=(Particles.of((Body(1.0, (0.0, 0.0, 0.0)),)),), contact=ContactModel())
    assert "radius > 0" in TAICHI.supports(point, SE)
    spinless = Scene(parts=(Particles.of((Body(1.0, (0.0, 0.0, 0.0), radius=0.1),)),),
                     contact=ContactModel(friction=0.5))
    assert "moment of inertia" in TAICHI.supports(spinless, SE)
    assert TAICHI.supports(Scene(parts=spinless.parts, contact=ContactModel()), SE) is None
    bare_walls = Scene(parts=(Particles.of((Body(1.0, (0.0, 0.0, 1.0), radius=0.1),)),
                              Walls.of((Wall((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),))))
    assert "contact model" in TAICHI.supports(bare_walls, SE)
    hinged = Scene(parts=(Particles.of((Body(1.0, (0.0, 0.0, -1.0), radius=0.1, inertia=0.004),)),
                          Joints.of((Joint(0, (0.0, 0.0, 0.0), 1.0),))), contact=ContactModel())
    assert "hinged" in TAICHI.supports(hinged, SE)
    with pytest.raises(ValueError, match="formulation"):
        TAICHI.build(scene, 1e-3, SE, "kkt")
