"""MuJoCo's spring-network formulation "flex" (adapters/mujoco_engine/network_flex.py): a hair
as a 1-D flexcomp discrete elastic rod plus stretch tendons.

Oracles: (1) MuJoCo's bending force at one bent vertex against the derived mapping
E I = k_b (l0 + l1) / 2 with the tan measure, U = 1/2 k_b (2 tan(phi/2))^2, to round-off;
(2) the static equilibrium of an INEXTENSIBLE hinge chain under gravity, solved here to 1e-15
for both bending measures (refsim's 1/2 k_b phi^2 and MuJoCo's tan): the settled MuJoCo hair
must sit on the tan equilibrium within what its stretch tendons let the chain lengthen.
mujoco is imported on purpose: CI must have every engine (fail, never skip).
"""
import json

import mujoco  # used directly; also: CI must have every engine (fail, never skip)
import numpy as np
import pytest
from scipy.optimize import fsolve

from refsim.engine import jsonable
from refsim.observation import check_observation
from refsim.registry import get_engine
from refsim.scene import Scene
from refsim.scene.networks import SpringNetwork

MJ = get_engine("mujoco")
EPS = np.finfo(float).eps
G = 9.81


def hair(links=8, l=0.1, kb=200.0, m=0.01, tip=0.1, k=1e5, drag=2.0, bend_last=0.0,
         gravity=-G):
    """Chain along x, nodes 0 and 1 pinned (clamped root), hinges at every interior node (rest
    angle 0), heavy tip; the last node optionally turned down by `bend_last` rad."""
    n = links + 2
    x = np.zeros((n, 3))
    x[:, 0] = l * np.arange(n)
    x[-1] = x[-2] + l * np.array([np.cos(bend_last), 0.0, -np.sin(bend_last)])
    masses = np.full(n, m)
    masses[-1] = tip
    net = SpringNetwork(positions=x, masses=masses, edges=np.c_[np.arange(n - 1), np.arange(1, n)],
                        stiffness=k, rest_length=l, damping=0.0,
                        hinges=np.c_[np.arange(n - 2), np.arange(1, n - 1), np.arange(2, n)],
                        hinge_stiffness=kb, hinge_rest_angle=0.0, pinned=[0, 1])
    return Scene(parts=(net,), gravity=(0.0, 0.0, gravity), linear_drag=drag)


def chain_equilibrium(net, kb, measure):
    """Turning angles (down) at nodes 1..n-2 of the inextensible chain at rest: moment(theta_j)
    = sum_{k > j} m_k g (x_k - x_j) . x (gravity's moment about node j), solved by fsolve."""
    masses, l, n = net.masses, float(net.rest_length[0]), len(net)

    def arms(theta):
        psi = np.cumsum(theta)  # absolute angle of the segment leaving node j
        xs = np.concatenate([[0.0], np.cumsum(l * np.cos(psi))])  # nodes 1..n-1
        return np.array([np.sum(masses[j + 2:] * G * (xs[j + 1:] - xs[j]))
                         for j in range(n - 2)])

    theta = fsolve(lambda t: measure(t) - arms(t) / kb, np.zeros(n - 2), xtol=1e-15)
    psi = np.cumsum(theta)
    return theta, -np.sum(l * np.sin(psi))  # the tip's z


def tan_moment(theta):
    """MuJoCo's moment / k_b: d/dtheta 1/2 (2 tan(theta/2))^2."""
    return 2 * np.tan(theta / 2) / np.cos(theta / 2) ** 2


# -- the mapping, to round-off ------------------------------------------------------------------
@pytest.mark.parametrize("phi", [0.01, 0.5, 1.5])
def test_bending_force_is_the_mapped_tan_measure(phi):
    """Only the last vertex but one is bent (by phi): the force on the tip, perpendicular to
    the last edge, is k_b tan_moment(phi) / l. Round-off: ~20 roundings in MuJoCo's curvature
    binormal, tan and the chain rule, and in young = E I / I and back: 64 eps relative."""
    kb, l = 200.0, 0.1
    sim = MJ.build(hair(kb=kb, l=l, bend_last=phi, gravity=0.0, drag=0.0), 1e-4,
                   "symplectic_euler", "flex")
    mujoco.mj_forward(sim.model, sim.data)
    tip_force = sim.data.qfrc_passive[sim._dof_at[-1]]
    normal = np.array([-np.sin(phi), 0.0, -np.cos(phi)])  # the direction that opens phi
    expected = kb * tan_moment(phi) / l
    assert abs(tip_force @ normal + expected) <= 64 * EPS * expected  # restoring: -dU/dx
    along = np.array([np.cos(phi), 0.0, -np.sin(phi)])
    # the tendon is at its rest length up to the rounding of the positions (|x| <= 1 m): its
    # force k (L - L0) is at most k 4 eps |x|
    assert abs(tip_force @ along) <= 64 * EPS * expected + 1e5 * 4 * EPS * 1.0


def test_initial_state_round_trips_and_twist_stays_zero():
    scene = hair(bend_last=0.3)
    sim = MJ.build(scene, 1e-4, "symplectic_euler", "flex")
    obs = sim.observe()
    check_observation(obs, scene)
    x = scene.part(SpringNetwork).positions
    # reference + (x - reference): two roundings of |x| <= 1 m
    assert np.abs(obs["x"] - x).max() <= 2 * EPS * np.abs(x).max()
    sim.step(2000)
    # exact zeros: planar motion, every out-of-plane term is a product with an exact 0
    assert sim.failure is None and np.all(sim.twist_angles() == 0.0)
    assert np.all(sim.observe()["x"][:, 1] == 0.0)  # planar: no y force anywhere


# -- statics: the hair under a small and a large tip load ---------------------------------------
def settled(scene, steps=40000, dt=1e-4, integrator="symplectic_euler"):
    sim = MJ.build(scene, dt, integrator, "flex")
    sim.step(steps)
    obs = sim.observe()
    assert sim.failure is None and np.abs(obs["v"]).max() < 1e-8  # at rest
    return obs["x"]


@pytest.mark.parametrize("tip, k, dt, steps", [(0.1, 1e5, 1e-4, 40000),
                                               (1.0, 1e6, 3e-5, 140000)])
def test_settled_hair_sits_on_the_tan_equilibrium(tip, k, dt, steps):
    """The tip of the settled hair equals the inextensible tan-measure equilibrium within the
    summed stretch of its edges (each edge's length change moves the tip by at most itself)
    plus the residual speed's share (v < 1e-8 m/s over the slowest rate ~ 10 1/s: 1e-9 m).
    Under the larger load (phi up to 0.04 rad) the phi-measure equilibrium (refsim's hinge)
    is 3.5e-5 m away from the tan one, more than 3 x that bound (1.0e-5 m): MuJoCo sits on
    the tan one."""
    scene = hair(tip=tip, k=k, drag=10.0 * tip)
    net = scene.part(SpringNetwork)
    x = settled(scene, steps=steps, dt=dt)
    stretch = np.abs(np.linalg.norm(np.diff(x, axis=0), axis=1) - net.rest_length).sum()
    _, tip_tan = chain_equilibrium(net, 200.0, tan_moment)
    _, tip_phi = chain_equilibrium(net, 200.0, lambda t: t)
    bound = stretch + 1e-9
    assert abs(x[-1, 2] - tip_tan) <= bound
    if tip > 0.5:
        assert abs(x[-1, 2] - tip_phi) > 3 * bound


def test_small_load_against_the_linear_cantilever_formula():
    """Linear hinge-chain statics: theta_j = M_j / k_b, tip z = -sum theta_j (x_tip - x_j); for
    a tip load P alone this is P l^3 N (N+1)(2N+1) / (6 E I) with E I = k_b l. Its
    linearisation error is O(psi^2) relative (psi: the tip segment's angle): bounded here by
    psi^2 (psi = 0.024 rad: 5.8e-4)."""
    scene = hair()
    net = scene.part(SpringNetwork)
    x0, m = net.positions[:, 0], net.masses
    nodes = np.arange(1, len(net) - 1)
    moments = np.array([np.sum(m[j + 1:] * G * (x0[j + 1:] - x0[j])) for j in nodes])
    theta = moments / 200.0
    linear_tip = -np.sum(theta * (x0[-1] - x0[nodes]))
    x = settled(scene)
    psi = theta.sum()
    assert abs(x[-1, 2] - linear_tip) <= psi ** 2 * abs(linear_tip)


# -- refusals, integrators, settings ------------------------------------------------------------
def test_offers_flex_only_for_a_hair_and_refuses_with_reasons():
    scene = hair()
    assert MJ.formulations(scene) == ("flex",)
    assert MJ.supports(scene, "rk4") is None and MJ.supports(scene, "discrete") is None
    assert "Verlet" in MJ.supports(scene, "velocity_verlet")
    assert "discrete" in MJ.supports(scene, "baraff_witkin")
    net = scene.part(SpringNetwork)
    bent = SpringNetwork(positions=net.positions, masses=net.masses, edges=net.edges,
                         stiffness=1e5, hinges=net.hinges, hinge_stiffness=200.0,
                         hinge_rest_angle=0.2, pinned=[0, 1])
    assert "rest angles must be 0" in MJ.supports(Scene(parts=(bent,)), "rk4")
    uneven = SpringNetwork(positions=net.positions, masses=net.masses, edges=net.edges,
                           stiffness=1e5, hinges=net.hinges,
                           hinge_stiffness=np.linspace(100, 200, len(net.hinges)), pinned=[0, 1])
    assert "one young modulus" in MJ.supports(Scene(parts=(uneven,)), "rk4")
    partial = SpringNetwork(positions=net.positions, masses=net.masses, edges=net.edges,
                            stiffness=1e5, hinges=net.hinges[:3], hinge_stiffness=200.0,
                            pinned=[0, 1])
    assert "EVERY interior vertex" in MJ.supports(Scene(parts=(partial,)), "rk4")


@pytest.mark.parametrize("integrator", ["rk4", "discrete"])
def test_other_integrators_settle_on_the_same_equilibrium(integrator):
    """Euler, RK4 and discrete share the fixed point (statics need no integrator): the same
    bound as the tan-equilibrium test."""
    scene = hair()
    net = scene.part(SpringNetwork)
    x = settled(scene, steps=20000 if integrator == "discrete" else 40000,
                integrator=integrator)
    stretch = np.abs(np.linalg.norm(np.diff(x, axis=0), axis=1) - net.rest_length).sum()
    _, tip_tan = chain_equilibrium(net, 200.0, tan_moment)
    assert abs(x[-1, 2] - tip_tan) <= stretch + 1e-9


def test_settings_declare_the_rod():
    sim = MJ.build(hair(), 1e-4, "discrete", "flex")
    s = json.loads(json.dumps(jsonable(sim.settings())))
    assert s["formulation"].startswith("flex")
    assert s["bending_rigidity_EI"] == pytest.approx(200.0 * 0.1, rel=1e-14)
    assert s["rayleigh_damping"] == 0.0 and s["twist_joints"] == 8
    assert "Hessian" in s["integrator"]["treated_implicitly"]
