"""The advection cases single_vortex and zalesak (issue 27, case 4): their references (exact
shapes, areas, markers), the flows' return, the bounds' discrete solutions against closed
forms, the orders in dt and h, and planted flow defects caught by the harness."""
import math

import numpy as np
import pytest
from ulp import assert_ulp

from refsim.integrators.first_order import get_first_order
from refsim.models.grid_fluid import prescribed_flow
from refsim.models.grid_fluid.level_set import LevelSetAdvection, area
from refsim.registry import get_case
from refsim.run.job import Job, run_job

SV, ZA = get_case("single_vortex"), get_case("zalesak")


def test_references_exact_areas_and_markers():
    p = ZA.variant_params("particles")
    x = ZA.markers(p)
    # markers on the boundary: |sdf| a few roundings of 100 m coordinates
    assert np.max(np.abs(ZA.sdf(p, x))) < 1e-12
    # the polygon through 256 markers: counter-clockwise, its area the exact one less the
    # chords' segments, (2 pi R) R (2 pi / k)^2 / 12 ~ 0.16 % of the area at most
    from refsim_cases.grid_fluids._advection import shoelace
    assert 0 < ZA.exact_area(p) - shoelace(x) < 2e-3 * ZA.exact_area(p)
    # the area rule on the exact signed distance converges to the closed form (O(h^2): the
    # chords; the slot's corners sit on grid-independent positions, no O(h) term measured)
    rule = [area(ZA.sdf(p, g.cell_points()), g.h) / ZA.exact_area(p) - 1
            for g in (ZA.grid({**p, "n": n}) for n in (100, 200))]
    assert abs(rule[1]) < 2e-3 and abs(rule[1]) < abs(rule[0])
    # after one turn the exact markers are the start (a rotation by 2 pi: cos, sin round)
    assert_ulp(ZA.exact_markers(p, [ZA.t_end(p)])[0], x, 64, "cos(2 pi), sin(2 pi) and the "
               "turn's products, each rounding at eps of ~100 m", scale=100.0)
    q = SV.variant_params("particles")
    assert SV.exact_area(q) == math.pi * 0.15 ** 2
    assert np.max(np.abs(SV.sdf(q, SV.markers(q)))) < 1e-15


def test_single_vortex_returns_the_shape_at_T():
    """The flow map at T is the identity: RK4 markers come back to 1e-13 m at T/1024 (measured
    1.2e-14 m; RK4's error at T falls 32x per halving from 3.3e-7 m at T/32, 3e-15 here,
    below the round-off 1024 steps x eps x G = 2.5 ~ 6e-13 m)."""
    from refsim_cases.grid_fluids._advection import _oracle_particles
    import json
    p = SV.variant_params("particles")
    gap, growth, steps = _oracle_particles(SV, json.dumps(p, sort_keys=True), "rk4", 1 / 1024)
    assert gap < 1e-13


@pytest.mark.parametrize("integrator,order,measured", [
    ("explicit_euler", 1, 1), ("midpoint", 2, 3), ("heun", 2, 3), ("rk4", 4, 5)])
def test_particle_orders_on_the_single_vortex(integrator, order, measured):
    """The discrete solutions' marker error at T over the sweep's dt falls at least at the
    stepper's order; measured one above for the 2- and 4-stage tableaux (1.0, 3.0, 3.0, 5.0:
    at T the field's time symmetry u(T - t) = -u(t) cancels their leading error term between
    the two halves of the run, as it does for the level set's backtraces)."""
    from refsim_cases.grid_fluids._advection import _oracle_particles
    import json
    p = SV.variant_params("particles")
    errs = [_oracle_particles(SV, json.dumps(p, sort_keys=True), integrator, dt)[0]
            for dt in SV.dts(p)[1:]]
    slope = math.log2(errs[0] / errs[1])
    assert slope > order - 0.3 and abs(slope - measured) < 0.3, errs  # near the asymptote


@pytest.mark.parametrize("integrator", ["explicit_euler", "heun", "rk4", "implicit_euler"])
def test_zalesak_particle_bound_is_the_steppers_run(integrator):
    """The case's bound on the rotation, the closed form c + R(h M)^k (p_0 - c), equals the
    stepper run step by step on the case's own velocity at every sample, to round-off
    (different operations: k steps vs a modal power; 1e3 n eps x 100 m)."""
    from refsim_cases.grid_fluids._advection import CaseFlow, _oracle_particles
    import json
    p = ZA.variant_params("particles")
    dt = ZA.reference_dt(p)
    gap, growth, steps = _oracle_particles(ZA, json.dumps(p, sort_keys=True), integrator, dt)
    stepper, flow = get_first_order(integrator), CaseFlow(
        lambda t, x: ZA.velocity(p, t, x), ZA.matrix(p))
    x = np.column_stack([ZA.markers(p), np.zeros(int(p["markers"]))])
    stride, worst = max(1, round(ZA.sample_dt(p) / dt)), 0.0
    for k in range(steps + 1):  # 64 vectorised steps
        if k % stride == 0 or k == steps:
            worst = max(worst, float(np.max(np.linalg.norm(
                x[:, :2] - ZA.exact_markers(p, [k * dt])[0], axis=-1))))
        x = stepper.step(flow, k * dt, x, dt)
    assert abs(gap - worst) <= 1e3 * steps * np.finfo(float).eps * 100  # round-off, above
    assert growth >= 1.0


def test_level_set_area_loss_first_order_in_h():
    """sl_linear:rk2 at dt = h, T = 1: numerical diffusion a (1 - a) h^2 / (2 dt) ~ h: the area
    loss halves with h (measured -0.327, -0.140; -0.064 at n = 128), Catmull-Rom's stays
    under 1 %."""
    losses = {}
    for interpolant in ("linear", "cubic"):
        for n in (32, 64):
            p = SV.variant_params("default", {"n": n})
            g = SV.grid(p)
            phi0 = SV.sdf(p, g.cell_points())
            m = LevelSetAdvection(phi0, g, lambda t, x: SV.velocity(p, t, x), interpolant,
                                  "rk2")
            m.step(g.h, n)
            losses[interpolant, n] = area(m.phi, g.h) / area(phi0, g.h) - 1
    order = math.log2(losses["linear", 32] / losses["linear", 64])
    assert losses["linear", 64] < 0 and 0.8 < order < 1.5, losses  # first order + next terms
    assert abs(losses["cubic", 32]) < 1e-2 and abs(losses["cubic", 64]) < 1e-2


def _row(case, variant, integrator):
    p = case.variant_params(variant)
    return run_job(Job(case.name, variant, "refsim", "", integrator, case.reference_dt(p)),
                   repeats=0)


@pytest.mark.parametrize("case,variant,integrator", [
    (SV, "default", "sl_cubic:rk2"), (SV, "particles", "rk4"), (SV, "particles", "midpoint"),
    (ZA, "level_set", "sl_cubic:rk3"), (ZA, "particles", "rk4")])
def test_in_house_rows_equal_their_discrete_solution(case, variant, integrator):
    row = _row(case, variant, integrator)
    assert row["status"] == "ok" and row["consistency"] == "consistent", row["tol_reason"]
    assert row["err_max"] <= row["tolerance"]


def test_planted_time_reversal_dropped_is_caught(monkeypatch):
    """cos(pi t/T) dropped from the model's flow (the engine's, not the case's): the shape does
    not come back, every row fails its bound by orders of magnitude."""
    original = prescribed_flow.Flow.velocity_2d
    monkeypatch.setattr(prescribed_flow.Flow, "velocity_2d",
                        lambda self, t, pts: original(self, 0.0, pts))  # cos(0) = 1
    for variant, integrator in (("default", "sl_cubic:rk2"), ("default", "sl_linear:rk2"),
                                ("particles", "rk4"), ("particles", "explicit_euler")):
        row = _row(SV, variant, integrator)
        assert row["consistency"] == "inconsistent", (integrator, row["err_max"],
                                                      row["tolerance"])


def test_planted_rotation_speed_off_by_a_thousandth_is_caught(monkeypatch):
    """omega 0.1 % fast in the model: one turn overshoots by 2 pi 1e-3 rad (0.04-0.25 m at
    r = 10-40 m), far above the particle steppers' second- and fourth-order bounds."""
    original = prescribed_flow.Flow.velocity_2d
    monkeypatch.setattr(prescribed_flow.Flow, "velocity_2d",
                        lambda self, t, pts: 1.001 * original(self, t, pts))
    for integrator in ("rk4", "midpoint"):
        row = _row(ZA, "particles", integrator)
        assert row["consistency"] == "inconsistent", (integrator, row["err_max"],
                                                      row["tolerance"])
