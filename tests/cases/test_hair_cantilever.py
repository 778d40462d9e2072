"""hair_cantilever: the exact discrete equilibrium (moment balance to round-off, its small-load
and N -> infinity limits with their rates), the in-house engine settling onto it within the
stated tolerance, and Baraff-Witkin at large dt reaching it in a few (Newton-like) steps."""
import numpy as np
import pytest

from refsim_cases.spring_network.hair_cantilever import (
    CASE,
    G,
    hair_equilibrium,
    moment_residual,
    tip_load_deflection,
)
from refsim.integrators.implicit import BaraffWitkin
from refsim.models.spring_network import NetworkSystem
from refsim.registry import get_engine
from refsim.scene import SpringNetwork

EPS = np.finfo(float).eps


def _loads(p):
    _, link, rigidity = CASE.dims(p)
    return link, rigidity / link, p["stretch_stiffness"], CASE.masses(p)[2:] * G


@pytest.mark.parametrize("variant", ["default", "heavy", "fine"])
def test_moment_balance_residual_is_round_off(variant):
    """Each residual sums N moments of size <= W_total L and k_b psi: 4 N eps of the largest."""
    link, k_bend, k_s, weights = _loads(CASE.variant_params(variant))
    psi, _ = hair_equilibrium(link, k_bend, k_s, weights)
    scale = max(np.sum(weights) * link * len(weights), k_bend * np.max(psi))
    assert np.max(np.abs(moment_residual(psi, link, k_bend, k_s, weights))) <= \
        4 * len(weights) * EPS * scale


def _tip_deflection(n_links, load, length=1.0, rigidity=1.0, k_s=1e6):
    link = length / n_links
    weights = np.zeros(n_links)
    weights[-1] = load
    _, x = hair_equilibrium(link, rigidity / link, k_s, weights)
    return -x[-1, 2]


def test_small_load_limit_and_its_rate():
    """delta(P) is odd in P (mirror z -> -z) and its stretch part is O(P^3) (tension P sin phi
    ~ P^2 times sin phi): delta / P = linear formula (1 + a P^2 + O(P^4)), so halving P divides
    the relative deviation by 4 (to O(P^2) of itself: within 4 +- 0.1 at P <= 0.02)."""
    n = 8
    formula = tip_load_deflection(1.0, 1.0 / n, n, 1.0)
    loads = 0.02 * 0.5 ** np.arange(4)
    deviation = [abs(_tip_deflection(n, P) / P / formula - 1) for P in loads]
    ratios = np.array(deviation[:-1]) / np.array(deviation[1:])
    assert np.all(np.abs(ratios - 4) <= 0.1)
    assert deviation[-1] <= 1e-5


def test_many_links_limit_and_its_rate():
    """P l^3 N (N+1)(2N+1) / (6 E I) / (P L^3 / (3 E I)) = 1 + 3/(2N) + 1/(2N^2): the oracle
    at a small load (relative O(P^2) ~ 1e-8 off the formula) shows the 1/N approach: the
    deviation halves (ratio 2 + O(1/N)) as N doubles."""
    load = 1e-4
    cantilever = load / 3
    deviations = []
    for n in (8, 16, 32, 64):
        delta = _tip_deflection(n, load)
        exact_ratio = 1 + 3 / (2 * n) + 1 / (2 * n * n)
        assert delta / cantilever == pytest.approx(exact_ratio, rel=1e-7)
        deviations.append(delta / cantilever - 1)
    ratios = np.array(deviations[:-1]) / np.array(deviations[1:])
    # (3/(2N) + 1/(2N^2)) / (3/(4N) + 1/(8N^2)) = 2 (6N + 2)/(6N + 1): within 0.05 of 2 at N >= 8
    assert np.all(np.abs(ratios - 2) <= 0.05)


@pytest.mark.parametrize("integrator", ["symplectic_euler", "velocity_verlet", "rk4",
                                        "baraff_witkin"])
def test_engine_settles_onto_the_oracle_within_tolerance(integrator):
    p = CASE.variant_params("default")
    dt = CASE.reference_dt(p)
    sim = get_engine("refsim").build(CASE.scene(p), dt, integrator, "")
    sim.step(round(CASE.t_end(p) / dt))
    err = np.linalg.norm(sim.observe()["x"] - CASE.reference_positions(p))
    tol, _ = CASE.tolerance(p, integrator, 1, dt, "", sim.settings())
    assert err <= tol
    # the bound is the linearised transient itself, not a loose cap: the error is a sizeable
    # part of it (the dominant mode's term)
    assert err >= 0.1 * CASE.linearised(p)["bound_at_end"]


@pytest.mark.parametrize("variant", ["default", "heavy", "fine"])
def test_baraff_witkin_at_large_dt_is_newton_on_the_statics(variant):
    """h -> inf: (M - h D - h^2 K) dv = h (f + h K v) gives x1 = x - K^-1 f + O(1/h): Newton's
    method on f(x) = 0, quadratic from the straight start; (x*, 0) is an exact fixed point at
    any h. Measured: default 1.6e-2, 6.2e-5, 2.0e-9, 2.2e-14 m; heavy reaches round-off in 7.
    8 steps must leave only the round-off bound 8 eps k_s L ||K^-1||."""
    p = CASE.variant_params(variant)
    scene = CASE.scene(p)
    system = NetworkSystem(scene.part(SpringNetwork), scene.gravity, scene.linear_drag)
    x = scene.part(SpringNetwork).positions[2:].reshape(-1)
    state, stepper, h = (x, np.zeros_like(x)), BaraffWitkin(), 1e4
    for k in range(8):
        state = stepper.step(system, k * h, state, h)
    err = np.linalg.norm(state[0] - CASE.equilibrium(p).reshape(-1))
    assert err <= CASE.linearised(p)["roundoff"]
