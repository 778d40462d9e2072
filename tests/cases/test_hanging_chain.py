"""hanging_chain: the exact discrete equilibrium closes the chain to round-off and satisfies
every node's force balance in the in-house model; it converges to the catenary at O(N^-2);
the in-house engine settles onto it with each of the four steppers within the derived
transient bound, and its energy does not rise under the drag (the dissipative steppers)."""
import math

import numpy as np
import pytest

from refsim_cases.spring_network._chain import catenary_parameter, catenary_sag, chain_equilibrium
from refsim_cases.spring_network.hanging_chain import CASE, G
from refsim.models.spring_network import NetworkSystem
from refsim.registry import get_engine

ENGINE = get_engine("refsim")
EPS = np.finfo(float).eps
STEPPERS = ["symplectic_euler", "velocity_verlet", "rk4", "baraff_witkin"]


@pytest.mark.parametrize("stiffness", [40.0, 4000.0, math.inf])
def test_root_find_closes_the_chain_to_round_off(stiffness):
    eq = chain_equilibrium(np.full(7, 0.0981), 0.125, stiffness, 0.8)
    # the residual is the sum of 8 link vectors of length <= 0.2 m: a few eps of the span
    assert eq.residual <= 8 * EPS
    assert eq.first_vertical == pytest.approx(-3.5 * 0.0981, rel=1e-12)  # symmetric chain


@pytest.mark.parametrize("variant", ["default", "stiff"])
def test_equilibrium_balances_every_node_of_the_in_house_model(variant):
    p = CASE.variant_params(variant)
    x_eq = CASE.equilibrium_positions(p)
    system = NetworkSystem(CASE.network(p, x_eq), (0.0, 0.0, -G), 0.0)
    x_free = x_eq[system.free].reshape(-1)
    accel = system.accel(0.0, x_free, np.zeros_like(x_free))
    # the node positions are stored to eps/2 of the span S per component, so each link's
    # length |d| to sqrt 3 eps S and its tension k (|d| - l0) to k sqrt 3 eps S; a node sums
    # two links: |a| <= 2 k sqrt 3 eps S / m (plus the tensions' own rounding, eps T / m)
    k, m = p["axial_stiffness"] * p["links"] / p["length"], p["mass"] / p["links"]
    bound = (2 * k * math.sqrt(3) * p["span"] + 2 * CASE.equilibrium(p).tensions.max()) \
        * EPS / m
    assert np.max(np.abs(accel)) <= bound


def test_discrete_chain_converges_to_the_catenary_at_second_order():
    """Inextensible links, node masses M / N: the balance is a second-order (central)
    discretisation of the catenary's, so sag and H err by O(N^-2)."""
    length, mass, span = 1.0, 0.08, 0.8
    links = np.array([16, 32, 64, 128])
    sag_err, h_err = [], []
    a = catenary_parameter(length, span)
    for n in links:
        eq = chain_equilibrium(np.full(n - 1, mass / n * G), length / n, math.inf, span)
        sag_err.append(abs(-eq.nodes[:, 1].min() - catenary_sag(length, span)))
        h_err.append(abs(eq.horizontal - mass / length * G * a))
    for err in (sag_err, h_err):
        slopes = -np.diff(np.log(err)) / np.diff(np.log(links))
        assert np.all(np.abs(slopes - 2.0) < 0.05), slopes


def test_bad_span_names_the_parameter():
    with pytest.raises(ValueError, match="span"):
        chain_equilibrium(np.full(3, 1.0), 0.25, 10.0, 1.5)
    with pytest.raises(ValueError, match="span"):
        CASE.scene(CASE.validate({"span": 2.0}))


def _settle(p, integrator):
    dt = CASE.reference_dt(p)
    steps = round(CASE.t_end(p) / dt)
    sim = ENGINE.build(CASE.scene(p), dt, integrator, "")
    energies = [CASE.energy(p, {k: np.asarray(v)[None] for k, v in sim.observe().items()})[0]]
    for _ in range(steps):
        sim.step(1)
        o = sim.observe()
        energies.append(CASE.energy(p, {k: np.asarray(v)[None] for k, v in o.items()})[0])
    return o, np.array(energies), dt


@pytest.mark.parametrize("integrator", STEPPERS)
def test_in_house_engine_settles_on_the_exact_equilibrium(integrator):
    p = CASE.variant_params("default")
    o, energies, dt = _settle(p, integrator)
    err = np.max(np.linalg.norm(o["x"] - CASE.equilibrium_positions(p), axis=1))
    tol, _ = CASE.tolerance(p, integrator, 1, dt)
    assert err <= tol
    # the start's deviation is gone to 1e-6 of itself: the bound is not vacuous
    assert tol < 1e-5 * CASE.motion_scale(p)
    if integrator != "symplectic_euler":  # its discrete energy oscillates at O(h): no claim
        # every energy evaluation rounds |E| (~ the gravity term) by a few eps
        assert np.max(np.diff(energies)) <= 8 * EPS * np.max(np.abs(energies))


def test_case_declares_no_order_and_one_dt():
    p = CASE.variant_params("default")
    assert CASE.order_meaningful is False and CASE.tolerance_norm == "err_final"
    assert CASE.dts(p) == [CASE.reference_dt(p)]


@pytest.mark.parametrize("integrator", STEPPERS + ["symplectic_euler_dk"])
def test_bound_is_the_methods_own_transient_within_a_small_factor(integrator):
    """The bound is the named method's exact discrete transient (linearised, actual start)
    plus the first-order nonlinear term, times the safety factor 2: on the default it is
    within 1..6 x the error (measured 2.2..5.2; the old norm bound was 3..46 x)."""
    p = CASE.variant_params("default")
    o, _, dt = _settle(p, integrator)
    err = np.max(np.linalg.norm(o["x"] - CASE.equilibrium_positions(p), axis=1))
    tol, why = CASE.tolerance(p, integrator, 1, dt)
    assert err <= tol <= 6.0 * err, why


def _final_error(p, defect, integrator):
    from refsim_adapters.planted_defects.engines import register_all
    register_all()
    dt = CASE.reference_dt(p)
    sim = get_engine(f"planted_{defect}").build(CASE.scene(p), dt, integrator, "")
    sim.step(round(CASE.t_end(p) / dt))
    x = sim.observe()["x"]
    sim.close()
    return float(np.max(np.linalg.norm(x - CASE.equilibrium_positions(p), axis=1)))


@pytest.mark.parametrize("defect, integrator", [
    ("heun_as_rk4", "rk4"), ("euler_as_verlet", "velocity_verlet"),
    ("gravity_plus_0.1pct", "rk4"), ("stiffness_plus_1pct", "rk4"),
    ("rest_length_plus_0.5pct", "rk4")])
def test_planted_defects_exceed_the_named_methods_bound(defect, integrator):
    """Heun and explicit Euler are unstable at w_max dt = 1.5 (errors 1e21, 1e45 m); a wrong
    gravity, stiffness or rest length moves the equilibrium (4e-5, 4e-4, 3e-3 m against a bound
    of 2e-9 m). Not caught, and why: Kutta's RK3 as rk4 (its transient, 5.4e-10 m, is smaller
    than RK4's 7.5e-10 m: it damps the top modes more at y = 1.5) and v damping of 1e-4 a step
    (7.4e-10 m: extra damping only shortens a transient to the same fixed point)."""
    p = CASE.variant_params("default")
    tol, _ = CASE.tolerance(p, integrator, 4 if integrator == "rk4" else 2,
                            CASE.reference_dt(p))
    assert _final_error(p, defect, integrator) > tol
