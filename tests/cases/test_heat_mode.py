"""heat_mode: every scheme follows its exact discrete solution G^n phi to round-off, converges
in dt at its order and in h at order 2 (order 4 for FTCS at r = 1/6 in 1D), and the explicit
stability limits are r = 1/(2d), measured by `refsim stress`."""
import math

import numpy as np
import pytest

from refsim_cases.grid_evolution.heat_mode import CASE
from refsim.registry import get_engine
from refsim.run.job import Job, run_job

ENGINE = get_engine("refsim")
SCHEMES = ["explicit_euler", "midpoint", "heun", "rk4", "implicit_euler", "crank_nicolson"]


def _run(p, integrator, dt, steps):
    sim = ENGINE.build(CASE.scene(p), dt, integrator, "")
    sim.step(steps)
    return sim.observe()["grid.u"]


@pytest.mark.parametrize("variant", ["1d", "2d", "3d", "neumann", "periodic"])
@pytest.mark.parametrize("integrator", SCHEMES)
def test_each_scheme_is_its_exact_discrete_solution_to_roundoff(variant, integrator):
    p = CASE.variant_params(variant)
    dt, steps = CASE.dt_of(p, 0.125), 60
    u = _run(p, integrator, dt, steps)
    oracle = CASE.factor(p, integrator, dt).real ** steps * CASE.grid(p).mode()
    bound, _ = CASE.roundoff(p, integrator, dt)
    bound *= steps / round(CASE.t_end(p) / dt)  # the case's bound is for its whole run
    assert np.max(np.abs(u - oracle)) <= bound


def _errors(p, integrator, rs):
    out = []
    for r in rs:
        row = run_job(Job("heat_mode", "1d", "refsim", "", integrator, CASE.dt_of(p, r)),
                      repeats=0)
        out.append(row["err_max"])
    return np.array(out)


@pytest.mark.parametrize("integrator,order", [("explicit_euler", 1), ("implicit_euler", 1),
                                              ("crank_nicolson", 2), ("midpoint", 2)])
def test_time_error_against_the_semi_discrete_decay_has_the_scheme_order(integrator, order):
    p = CASE.variant_params("1d")
    rs = [0.25, 0.125, 0.0625]
    err = _errors(p, integrator, rs)
    slopes = np.diff(np.log(err)) / np.diff(np.log(rs))
    assert np.all(np.abs(slopes - order) < 0.05), slopes


def _continuum_error(cells, r, integrator="explicit_euler"):
    p = CASE.validate({"dim": 1, "cells": cells})
    dt = CASE.dt_of(p, r)
    steps = round(0.05 / dt)
    u = _run(p, integrator, dt, steps)
    g = CASE.grid(p)
    return np.max(np.abs(u - math.exp(g.continuum_eigenvalue() * steps * dt) * g.mode()))


@pytest.mark.parametrize("r,order", [(0.25, 2), (1.0 / 6, 4)])
def test_ftcs_space_time_order_in_h_and_the_r_one_sixth_superconvergence(r, order):
    """dt = r h^2: FTCS's error against the PDE is O(h^2) except at r = 1/6, where the
    leading terms cancel (truncation D h^2 (6 r - 1) u_xxxx / 12) and it is O(h^4). t = 0.05 s
    holds an exact number of steps for every h here."""
    cells = [8, 16, 32]
    err = np.array([_continuum_error(c, r) for c in cells])
    slopes = -np.diff(np.log(err)) / np.diff(np.log(cells))
    assert np.all(np.abs(slopes - order) < 0.15), slopes


def test_crank_nicolson_converges_at_order_two_in_h():
    cells = [8, 16, 32]
    err = np.array([_continuum_error(c, 1.0 / 64, "crank_nicolson") for c in cells])
    slopes = -np.diff(np.log(err)) / np.diff(np.log(cells))
    assert np.all(np.abs(slopes - 2) < 0.05), slopes


def test_the_slides_1d_bound_diverges_in_2d_but_not_in_1d():
    rows = {v: run_job(Job("heat_mode", v, "refsim", "", "explicit_euler",
                           CASE.dt_of(CASE.variant_params(v), 0.5)), repeats=0)
            for v in ("1d", "2d")}
    assert rows["1d"]["status"] == "ok" and (rows["1d"]["consistency"] == "consistent")
    assert rows["2d"]["status"] == "diverged"


@pytest.mark.parametrize("variant,limit", [("1d", 0.5), ("2d", 0.25), ("3d", 1.0 / 6)])
def test_stress_measures_the_ftcs_limit_one_over_2d(variant, limit, stress_limits):
    table = stress_limits("heat_mode", variant, ["explicit_euler", "implicit_euler"])
    assert table.loc["explicit_euler", "theory"] == pytest.approx(limit, rel=1e-12)
    assert table.loc["explicit_euler", "agrees"]
    assert table.loc["explicit_euler", "measured"] >= limit  # the criterion lands above it
    assert math.isinf(table.loc["implicit_euler", "measured"])


@pytest.mark.parametrize("integrator", ["implicit_euler", "crank_nicolson"])
@pytest.mark.parametrize("r", [10.0, 100.0, 1000.0])
def test_implicit_schemes_never_grow_noise_far_past_the_explicit_limit(integrator, r):
    """Unconditional stability, beyond the stress search's short runs at large r: 200 steps
    on noise (every mode, the sawtooth included) never raise the energy 1/2 sum w u^2
    (|R(z)| <= 1 on the whole negative axis: implicit Euler 1/(1 + x), CN |1 - x/2|/(1 + x/2)),
    up to the round-off of the solves."""
    p = CASE.variant_params("2d", {"initial": "noise", "boundary": "periodic"})
    sim = ENGINE.build(CASE.scene(p), CASE.dt_of(p, r), integrator, "")
    energies = [float(CASE.energy(p, {"grid.u": sim.observe()["grid.u"][None],
                                      "t": np.zeros(1)})[0])]
    for _ in range(20):
        sim.step(10)
        energies.append(float(CASE.energy(p, {"grid.u": sim.observe()["grid.u"][None],
                                              "t": np.zeros(1)})[0]))
    assert np.all(np.diff(energies) <= 1e-12 * energies[0]), energies
