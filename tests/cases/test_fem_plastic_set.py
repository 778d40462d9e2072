"""Plastic set (cases/fem/plastic_set.py): the single regular tetrahedron's deviatoric mode is
the closed form's oscillator, the in-house steppers equal the case's exact discrete solutions,
the permanent set meets the yield rule's closed form, and the bound catches sigma_y or E
0.1 % off."""
import numpy as np
import pytest

from refsim.models.fem.assembly import Assembler
from refsim.models.fem.model import ElasticBody
from refsim.registry import get_case
from refsim.run.job import Job, run_job

CASE = get_case("plastic_set")


@pytest.mark.parametrize("variant", ["default", "plane_strain"])
def test_the_deviatoric_mode_has_omega_squared_2_mu_k(variant):
    """refsim's stiffness and lumped mass of the tetrahedron: K x_N = omega^2 M x_N for the
    mode x_N = N (X - c), omega^2 = 2 mu k, k = 8 / (rho a^2) (tetrahedron) or 6 / (rho a^2)
    (equilateral triangle, plane strain) (12 or 6 dofs, a few roundings: 1e-12)."""
    p = CASE.variant_params(variant)
    mesh = CASE.scene(p).parts[0]
    body = ElasticBody.of(mesh)
    assembler = Assembler(body)
    k = assembler.stiffness(body.elements.rest).toarray()
    m = np.repeat(assembler.lumped_mass(p["density"]), body.d)
    nodes, centre = CASE._rest(p)
    mode = ((nodes - centre) @ CASE.direction(p).T)[:, :body.d].reshape(-1)
    omega2 = CASE.constants(p)["omega"] ** 2
    assert np.abs(k @ mode - omega2 * m * mode).max() <= 1e-12 * omega2 * np.abs(mode).max()


def test_the_closed_form_permanent_set():
    """overdrive sqrt(7): e_p = e_y (r^2 - 1) / 2 = 3 e_y; e(t) continuous at both switches."""
    p = CASE.variant_params("default")
    c = CASE.constants(p)
    assert c["e_p"] == pytest.approx(3 * c["e_y"], rel=1e-13)
    for t in (c["t1"], c["t_max"]):
        left, right = CASE.strain(p, [t * (1 - 1e-12), t * (1 + 1e-12)])
        assert abs(left - right) <= 1e-12 * c["e_p"] + 2e-12 * t * c["v0"]
    assert CASE.strain(p, [c["t_end"]])[0] == pytest.approx(c["e_p"], abs=1e-15)


@pytest.mark.parametrize("variant", ["default", "hardening"])
def test_the_closed_form_balances_energy(variant):
    """In e-space (e'' = -k s(e)) the initial kinetic energy v0^2 / 2 is, at the turning
    point, k times the work of s: mu e_y^2 + s_y (e_max - e_y) + h' (e_max - e_y)^2 / 2; and
    e_p = 2 mu (e_max - e_y) / (2 mu + 2 H / 3) leaves the unloading amplitude at
    s_max / (2 mu). Checks the plastic phase's solution independently (to 1e-12)."""
    p = CASE.variant_params(variant)
    c = CASE.constants(p)
    rise = c["e_max"] - c["e_y"]
    work = c["mu"] * c["e_y"] ** 2 + c["s_y"] * rise + c["slope"] * rise ** 2 / 2
    assert c["k"] * work == pytest.approx(c["v0"] ** 2 / 2, rel=1e-12)
    s_max = c["s_y"] + c["slope"] * rise
    assert c["e_max"] - c["e_p"] == pytest.approx(s_max / (2 * c["mu"]), rel=1e-12)
    assert CASE.strain(p, [c["t_max"]])[0] == pytest.approx(c["e_max"], rel=1e-12)


@pytest.mark.parametrize("variant", ["default", "hardening", "plane_strain"])
@pytest.mark.parametrize("integrator", ["explicit_euler", "symplectic_euler",
                                        "velocity_verlet", "rk4", "implicit_euler",
                                        "baraff_witkin"])
def test_the_engine_is_the_exact_discrete_solution(integrator, variant):
    """err_max equals the case's discrete solution's deviation to round-off (the reduction to
    one degree of freedom is exact), and the permanent set read from the nodes at t_end is
    e_p within the method's own error there."""
    p = CASE.variant_params(variant)
    dt = CASE.reference_dt(p)
    row = run_job(Job("plastic_set", variant, "refsim", "", integrator, dt), repeats=0)
    assert row["status"] == "ok" and row["consistency"] == "consistent", row["reason"]
    bound, _ = CASE.tolerance(p, integrator, 1, dt)
    steps = int(round(CASE.t_end(p) / dt))
    e = CASE.discrete(p, integrator, dt, steps)
    nodes, centre = CASE._rest(p)
    size = np.linalg.norm((nodes - centre) @ CASE.direction(p).T)
    deviation = size * np.max(np.abs(e - CASE.strain(p, np.arange(steps + 1) * dt)))
    assert abs(row["err_max"] - deviation) <= bound - deviation + 1e-15  # the round-off part
    assert row["permanent_strain"] == pytest.approx(e[-1], abs=1e-12)
    assert row["permanent_strain_exact"] == CASE.constants(p)["e_p"]


@pytest.mark.parametrize("integrator, margin", [("velocity_verlet", 1.5), ("rk4", 100.0),
                                                ("symplectic_euler", 1.5)])
@pytest.mark.parametrize("change", [{"yield_stress": 10.01}, {"yield_stress": 9.99},
                                    {"youngs_modulus": 1001.0}, {"youngs_modulus": 999.0}])
def test_a_parameter_0_1_percent_off_fails_the_bound(integrator, margin, change):
    """An engine with sigma_y or E 0.1 % off follows the discrete solution of the changed
    oscillator: sigma_y moves e_p by 0.13 % (2.6e-5 m at the nodes), E the frequency and e_y;
    measured past the bound by 1.8-4.4x (Verlet, symplectic Euler: bound 1.2e-5 m; 9.7-15x at
    the sweep's omega dt = 0.02) and 194-257x (RK4: 1.6e-7 m) at the reference omega dt =
    0.04; the first-order methods' own errors (1e-3 m) hide it (0.96-1.04x), not asserted."""
    p = CASE.variant_params("default")
    dt = CASE.reference_dt(p)
    steps = int(round(CASE.t_end(p) / dt))
    bound, _ = CASE.tolerance(p, integrator, 2, dt)
    off = CASE.discrete({**p, **change}, integrator, dt, steps)
    nodes, centre = CASE._rest(p)
    size = np.linalg.norm((nodes - centre) @ CASE.direction(p).T)
    error = size * np.max(np.abs(off - CASE.strain(p, np.arange(steps + 1) * dt)))
    assert error > margin * bound, error / bound


def _green():
    p = CASE.variant_params("green")
    return p, CASE._green(p)


def test_the_green_reference_balances_energy():
    """StVK along l = diag F: the kinetic energy |l'|^2 / (2k) per volume (lumped masses
    rho V / 4, sum (X - c)(X - c)^T = a^2 / 2 I), the stored mu |E_e|^2 + lam/2 tr(E_e)^2 and
    the plastic work 2 mu e_y |E_p| (S : n = 2 mu e_y while flowing) sum to the start's kinetic
    energy; checks the reference solve (DOP853, rtol 1e-13) independently: measured 5.9e-13,
    bound 1e-11 (its rtol over ~100 steps of its own)."""
    _, g = _green()
    t = np.linspace(0.0, g.t_end, 401)
    piece = np.searchsorted(g.breaks, t)
    y = np.concatenate([sol(t[piece == i]) for i, sol in enumerate(g.pieces)], axis=1)
    zero, total = np.zeros(3), []
    for ti, l, v in zip(t, y[:3].T, y[3:].T):
        e, ep = g.ret(l, zero) if ti < g.t_max else (0.5 * (l * l - 1) - g.e_p, g.e_p)
        total.append(v @ v / (2 * g.k) + g.mu * e @ e + g.lam / 2 * np.sum(e) ** 2
                     + 2 * g.mu * g.e_y * np.linalg.norm(ep))
    assert np.max(np.abs(np.array(total) / total[0] - 1)) <= 1e-11
    assert np.sum(g.e_p) == 0.0 and g.t_max < g.t_end  # refsim's flow keeps volume


@pytest.mark.parametrize("integrator", ["explicit_euler", "symplectic_euler", "velocity_verlet",
                                        "rk4", "implicit_euler", "baraff_witkin"])
def test_the_engine_is_the_green_discrete_solution(integrator):
    """The in-house engine's four nodes on StVK with plasticity equal the case's reduced
    3-stretch discrete solution (GreenTet) to round-off: err_max is its deviation from the
    reference within the round-off term (measured 4e-14 m)."""
    p, g = _green()
    dt = CASE.reference_dt(p)
    row = run_job(Job("plastic_set", "green", "refsim", "", integrator, dt), repeats=0)
    assert row["status"] == "ok" and row["consistency"] == "consistent", row["reason"]
    steps = int(round(g.t_end / dt))
    lam = CASE.discrete(p, integrator, dt, steps)
    nodes, centre = CASE._rest(p)
    t = np.arange(steps + 1) * dt
    deviation = np.max(np.linalg.norm((lam - g.stretches(t))[:, None, :] * (nodes - centre),
                                      axis=(1, 2)))
    bound, _ = CASE.tolerance(p, integrator, 1, dt)
    assert abs(row["err_max"] - deviation) <= bound - deviation + 1e-15
    assert row["permanent_strain"] == pytest.approx(g.n @ (lam[-1] - 1), abs=1e-12)


@pytest.mark.parametrize("integrator, margin", [("velocity_verlet", 1.5), ("rk4", 20.0),
                                                ("symplectic_euler", 1.5)])
@pytest.mark.parametrize("change", [{"yield_stress": 10.01}, {"yield_stress": 9.99},
                                    {"youngs_modulus": 1001.0}, {"youngs_modulus": 999.0}])
def test_green_a_parameter_0_1_percent_off_fails_the_bound(integrator, margin, change):
    """The green bound catches sigma_y or E 0.1 % off: the changed element's discrete
    solution against the unchanged reference passes the bound by 1.7-4.2x (Verlet, symplectic
    Euler: bound 1.2e-5 m) and 38-52x (RK4: 7.6e-7 m) at omega dt = 0.04; the first-order
    methods' own errors (1e-3 m) hide it (0.96-1.04x), not asserted."""
    p, g = _green()
    dt = CASE.reference_dt(p)
    steps = int(round(g.t_end / dt))
    bound, _ = CASE.tolerance(p, integrator, 2, dt)
    off = CASE.discrete({**p, **change}, integrator, dt, steps)
    nodes, centre = CASE._rest(p)
    gap = (off - g.stretches(np.arange(steps + 1) * dt))[:, None, :] * (nodes - centre)
    error = np.max(np.linalg.norm(gap, axis=(1, 2)))
    assert error > margin * bound, error / bound
