"""pymunk's spring_network group: a zero-rest-length string (transverse z mode), a 10-link
hanging chain and a hair chain of hinges, against the in-house engine and exact oracles."""
from __future__ import annotations

import json

import numpy as np
import pymunk  # noqa: F401  (CI must have every engine: fail here, not skip)
import pytest
from scipy.optimize import root

from refsim_adapters.refsim_engine.groups.spring_network import NetworkSim
from refsim.models.spring_network import NetworkSystem
from refsim.registry import get_engine
from refsim.scene import Scene, SpringNetwork

EPS = np.finfo(float).eps
DK = "symplectic_euler_dk"
ULPS_PER_STEP = 16  # a step sums a few spring forces per node: each adds a few ulps of the
# largest term; 16 ulps of the state's scale per step bounds the accumulated difference of two
# summation orders (pymunk applies the springs one by one, numpy sums them per node)


def _chain_edges(n):
    return np.stack([np.arange(n - 1), np.arange(1, n)], 1)


def string_scene(n_free=10, k=100.0, m=0.01, spacing=0.1, amp=1e-2, mode=1):
    n = n_free + 2
    x = np.zeros((n, 3))
    x[:, 0] = spacing * np.arange(n)
    x[1:-1, 2] = amp * np.sin(mode * np.pi * np.arange(1, n_free + 1) / (n_free + 1))
    net = SpringNetwork(positions=x, masses=m, edges=_chain_edges(n), stiffness=k,
                        rest_length=0.0, pinned=[0, n - 1])
    return Scene(parts=(net,), gravity=(0, 0, 0))


def chain_scene(n_links=10, span=0.8, length=1.0, k=500.0, m=0.05, c=0.05, drag=0.02):
    n = n_links + 1
    x = np.zeros((n, 3))
    x[:, 0] = np.linspace(0, span, n)
    net = SpringNetwork(positions=x, masses=m, edges=_chain_edges(n), stiffness=k,
                        rest_length=length / n_links, damping=c, pinned=[0, n - 1])
    return Scene(parts=(net,), gravity=(0, 0, -9.81), linear_drag=drag)


def hair_scene(n_links=8, link=0.05, m=0.01, tip=0.05, kb=1.0, drag=0.2, turns=None,
               rest=0.0, gravity=-9.81):
    """Chain along x from a clamped root (nodes 0, 1 pinned); `turns` bends it in x-z."""
    n = n_links + 1
    phi = np.concatenate([[0.0], np.cumsum(np.zeros(n - 2) if turns is None else turns)])
    x = np.zeros((n, 3))
    x[1:, 0] = np.cumsum(link * np.cos(phi))
    x[1:, 2] = np.cumsum(link * np.sin(phi))
    masses = np.full(n, m)
    masses[-1] = tip
    hinges = np.stack([np.arange(n - 2), np.arange(1, n - 1), np.arange(2, n)], 1)
    net = SpringNetwork(positions=x, masses=masses, edges=_chain_edges(n), stiffness=1e5,
                        hinges=hinges, hinge_stiffness=kb, hinge_rest_angle=rest,
                        pinned=[0, 1])
    return Scene(parts=(net,), gravity=(0, 0, gravity), linear_drag=drag)


def run_pair(scene, dt, steps, variant=""):
    sim = get_engine("pymunk").build(scene, dt, DK, variant)
    ref = NetworkSim(scene, dt, DK, "")
    sim.step(steps)
    ref.step(steps)
    return sim.observe(), ref.observe()


def test_undamped_string_is_the_in_house_drift_kick_to_round_off():
    steps = 1000
    got, ref = run_pair(string_scene(), 1e-3, steps)
    for name in ("x", "v"):
        scale = np.abs(ref[name]).max()
        assert np.abs(got[name] - ref[name]).max() <= steps * ULPS_PER_STEP * EPS * scale
    # exact zeros: planar motion, every y term is a product with an exact 0
    assert np.all(got["x"][:, 1] == 0.0) and np.all(got["v"][:, 1] == 0.0)


def test_string_mode_oscillates_at_the_discrete_normal_mode_frequency():
    """Zero rest length: z obeys z'' = -(k/m) L z exactly, mode 1 has
    w = 2 sqrt(k/m) sin(pi / (2 (N + 1))); drift-kick maps (z, v) by
    M = [[1, h], [-h w^2, 1 - h^2 w^2]] per step (eigenvalues exp(+-i theta),
    theta = 2 arcsin(w h / 2)): pymunk's z must be M^n applied to the mode."""
    n_free, k, m, amp, h, steps = 10, 100.0, 0.01, 1e-2, 1e-3, 700
    scene = string_scene(n_free, k, m, amp=amp)
    w = 2 * np.sqrt(k / m) * np.sin(np.pi / (2 * (n_free + 1)))
    step_map = np.array([[1.0, h], [-h * w * w, 1.0 - h * h * w * w]])
    sim = get_engine("pymunk").build(scene, h, DK)
    shape = scene.part(SpringNetwork).positions[:, 2]
    for _ in range(5):
        sim.step(steps // 5)
        z_amp, v_amp = np.linalg.matrix_power(step_map, sim.steps) @ [amp, 0.0]
        got = sim.observe()
        bound = sim.steps * ULPS_PER_STEP * EPS
        assert np.abs(got["x"][:, 2] - shape / amp * z_amp).max() <= bound * amp
        assert np.abs(got["v"][:, 2] - shape / amp * v_amp).max() <= bound * amp * w
    theta = np.angle(np.linalg.eigvals(step_map)).max()
    assert theta == pytest.approx(2 * np.arcsin(w * h / 2), rel=1e-12)  # eig round-off


def _model_equilibrium(scene):
    system = NetworkSystem(scene.part(SpringNetwork), scene.gravity, scene.linear_drag)
    free = system.free
    start = np.array(scene.part(SpringNetwork).positions[free])
    span = scene.part(SpringNetwork).positions[:, 0].max()
    start[:, 2] -= 0.3 * np.sin(np.pi * start[:, 0] / span)  # sagging: the stable branch
    zero = np.zeros(start.size)
    sol = root(lambda q: system.accel(0.0, q, zero), start.reshape(-1), tol=1e-14)
    assert sol.success
    x_eq = sol.x.reshape(-1, 3)
    x_eq[:, 1] = 0.0  # no force along y at y = 0: the root finder's ~1e-17 there is noise
    return x_eq, free


@pytest.mark.parametrize("variant", ["", "space_damping"])
def test_hanging_chain_equilibrium_is_the_step_fixed_point(variant):
    """At v = 0 a pymunk step is x1 = x, v1 = (h f(x) / m) d + h g, with d = 1 for force
    drag, and d = space.damping^h = exp(-c h / m) for "space_damping" (cpBodyUpdateVelocity
    scales the spring impulse applied in preStep, not gravity). Its fixed point is therefore
    the model's exact equilibrium under gravity g / d: exact for "", shifted at O(h) for
    "space_damping". It must stay put to round-off."""
    h, steps = 1e-3, 2000
    scene = chain_scene()
    net = scene.part(SpringNetwork)
    d = np.exp(-scene.linear_drag * h / net.masses[0]) if variant else 1.0
    heavier = Scene(parts=(net,), gravity=tuple(np.array(scene.gravity) / d))
    x_eq, free = _model_equilibrium(heavier)
    x0 = np.array(net.positions)
    x0[free] = x_eq
    at_rest = Scene(parts=(SpringNetwork(
        positions=x0, masses=net.masses, edges=net.edges, stiffness=net.stiffness,
        rest_length=net.rest_length, damping=net.damping, pinned=net.pinned),),
        gravity=scene.gravity, linear_drag=scene.linear_drag)
    sim = get_engine("pymunk").build(at_rest, h, DK, variant)
    sim.step(steps)
    got = sim.observe()
    # the root find's residual (tol 1e-14 on accelerations ~ g) is below round-off
    assert np.abs(got["x"] - x0).max() <= steps * ULPS_PER_STEP * EPS * np.abs(x0).max()


def test_damped_chain_differs_from_the_in_house_step_at_first_order():
    """DampedSpring damps the axis velocity by exp(-c h / m_eff) per impulse pass after the
    kick; the in-house step applies -c (v.u) u explicitly. Both are first-order methods of the
    same ODE, so at a fixed time the difference halves with h (ratio 2 +- 10 %: the next term
    is O(h^2), below 10 % at these h)."""
    t_end = 0.05
    gaps = []
    for h in (4e-4, 2e-4, 1e-4):
        got, ref = run_pair(chain_scene(), h, round(t_end / h))
        gaps.append(np.abs(got["x"] - ref["x"]).max())
    ratios = np.array(gaps[:-1]) / np.array(gaps[1:])
    assert np.all((ratios > 1.8) & (ratios < 2.2)), ratios


def _inextensible_equilibrium(scene, guess):
    """Hinge chain with rigid links, clamped root along x: kb tau_i balances the moment of
    the outboard weights about node i (the exact discrete equilibrium)."""
    net = scene.part(SpringNetwork)
    kb, link = float(net.hinge_stiffness[0]), float(net.rest_length[0])
    weight = net.masses * -scene.gravity[2]

    def nodes(phi):
        ph = np.concatenate([[0.0], phi])
        return np.vstack([[0, 0], np.cumsum(link * np.stack([np.cos(ph), np.sin(ph)], 1), 0)])

    def residual(phi):
        pts, turns = nodes(phi), np.diff(np.concatenate([[0.0], phi]))
        lever = pts[None, :, 0] - pts[1:-1, None, 0]  # (hinge i, node j)
        outboard = np.arange(len(pts))[None, :] > np.arange(1, len(pts) - 1)[:, None]
        return kb * turns + np.sum(np.where(outboard, lever * weight, 0.0), axis=1)

    sol = root(residual, guess, tol=1e-14)
    # hybr may report no progress once at round-off: check the moments themselves (~0.2 N m
    # from the tip; 1e-14 N m is a few ulps of that sum)
    assert np.abs(residual(sol.x)).max() <= 1e-14
    return nodes(sol.x)


def test_hair_rigid_links_settle_on_the_inextensible_equilibrium():
    scene = hair_scene()
    engine = get_engine("pymunk")
    assert engine.formulations(scene) == ("rigid_links",)
    sim = engine.build(scene, 5e-4, DK, "rigid_links")
    sim.step(8000)
    got = sim.observe()
    x2 = got["x"][:, [0, 2]]
    d = np.diff(x2, axis=0)
    exact = _inextensible_equilibrium(scene, np.arctan2(d[1:, 1], d[1:, 0]))
    # what is left of the transient: the tip still moves at |v|; drag c/m_tip = 4 /s, a mode
    # of the hair at ~16 rad/s: the remaining displacement is below |v| / (4 /s)
    bound = np.abs(got["v"]).max() / 4.0
    assert np.abs(x2 - exact).max() <= bound
    assert bound < 1e-5  # and the run did settle (the tip hangs 0.19 m down)
    assert sim.link_gaps().max() < 1e-12  # pivots held to round-off at rest


def test_curved_hair_at_its_signed_rest_angles_stays_put():
    """No gravity, started bent exactly at its rest angles (turning the same way): the rotary
    springs' signed rest angle is the network's unsigned one with the initial turn's sign."""
    turns = np.linspace(0.1, 0.4, 7)
    scene = hair_scene(turns=-turns, rest=turns, gravity=0.0, drag=0.0)
    sim = get_engine("pymunk").build(scene, 1e-3, DK, "rigid_links")
    sim.step(1000)
    got = sim.observe()
    x0 = scene.part(SpringNetwork).positions
    assert np.abs(got["x"] - x0).max() <= 1000 * ULPS_PER_STEP * EPS * np.abs(x0).max()


def test_refusals_say_why():
    engine = get_engine("pymunk")
    assert "semi-implicit Euler" in engine.supports(string_scene(), "rk4")
    net = string_scene().part(SpringNetwork)
    membrane = Scene(parts=(SpringNetwork(
        positions=np.array(net.positions)[:, [0, 2, 1]] + [0, 0, 0.01], masses=0.01,
        edges=net.edges, stiffness=100.0, rest_length=0.0, pinned=net.pinned),),
        gravity=(0, 0, 0))
    assert "pymunk is 2D" in engine.supports(membrane)
    bent = hair_scene().part(SpringNetwork)
    loose = Scene(parts=(SpringNetwork(
        positions=bent.positions, masses=bent.masses, edges=bent.edges, stiffness=1e5,
        hinges=bent.hinges, hinge_stiffness=1.0, pinned=[0, 8]),), gravity=(0, 0, -9.81))
    assert "root prefix" in engine.supports(loose)
    with pytest.raises(ValueError, match="formulation"):
        engine.build(hair_scene(), 1e-3, DK, "")


@pytest.mark.parametrize("scene", [string_scene(), chain_scene(), hair_scene()],
                         ids=["string", "chain", "hair"])
def test_settings_are_json_and_name_the_formulation(scene):
    engine = get_engine("pymunk")
    for variant in engine.formulations(scene):
        sim = engine.build(scene, 1e-3, DK, variant)
        sim.step(3)
        described = json.loads(json.dumps(sim.settings()))
        assert described["formulation"] == (variant or "springs")
        assert described["integrator"]["name"] == DK
        assert sim.observe()["x"].shape == (len(scene.part(SpringNetwork)), 3)
