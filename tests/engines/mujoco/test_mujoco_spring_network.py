"""MuJoCo's spring-network group (adapters/mujoco_engine/groups/spring_network.py, formulation
"tendon") against the in-house engine with the same integrator, the exact discrete normal modes
of a zero-rest-length string and membrane, and a replica of MuJoCo's `discrete` step.

Round-off bounds (Euler / RK4 on the same forces). Both engines evaluate the same force formula
in a different operation order, so one acceleration differs by at most ~C eps A per stage, where
A is the SUM of the magnitudes of the terms that cancel in it (per node: k (|d| + L0) + c |dv|
per incident edge, m |g|, c_air |v|, over m): C = 16 roundings per stage (norm, division,
products, sums over <= 8 incident edges) and 4 stages for RK4. MuJoCo keeps the displacement
q = x - x0 (x0 + q rounded when observed), refsim keeps x: another eps |x| per step. Over N
steps of a stable step (omega h < 1 here) these local errors add up at most linearly, so
|dv| <= N C_s eps (h A + |v|) and |dx| <= N C_s eps (|x| + N h^2 A) with C_s = 16 x stages.
mujoco is imported on purpose: CI must have every engine (fail, never skip).
"""
import json

import mujoco  # noqa: F401  (fail, never skip, without the engine)
import numpy as np
import pytest
import scipy.sparse as sp

from refsim.engine import jsonable
from refsim.observation import check_observation
from refsim.registry import get_engine
from refsim.scene import Scene
from refsim.scene.networks import SpringNetwork

MJ, REF = get_engine("mujoco"), get_engine("refsim")
EPS = np.finfo(float).eps
ROUNDINGS = 16  # per force evaluation (see module doc)
STAGES = {"symplectic_euler": 1, "rk4": 4}
G = (0.0, 0.0, -9.81)


# -- scenes (the common brief's) --------------------------------------------------------------
def hanging_chain(links=10, sag=0.3):
    """Both ends pinned at z = 0, finite rest lengths (stretched a little), damping, drag."""
    x = np.zeros((links + 1, 3))
    x[:, 0] = np.linspace(0.0, 1.0, links + 1)
    x[:, 2] = -sag * np.sin(np.pi * x[:, 0])
    edges = np.c_[np.arange(links), np.arange(1, links + 1)]
    net = SpringNetwork(positions=x, masses=0.1, edges=edges, stiffness=500.0,
                        rest_length=0.11, damping=0.5, pinned=[0, links])
    return Scene(parts=(net,), gravity=G, linear_drag=0.05)


def string_mode(free=10, k=100.0, m=0.01, amp=0.01, mode=1):
    """Zero-rest-length string along x (tension k l), ends pinned, z mode `mode`; no gravity."""
    j = np.arange(free + 2)
    x = np.zeros((free + 2, 3))
    x[:, 0] = j / (free + 1)
    x[:, 2] = amp * np.sin(mode * np.pi * j / (free + 1))
    edges = np.c_[j[:-1], j[1:]]
    net = SpringNetwork(positions=x, masses=m, edges=edges, stiffness=k, rest_length=0.0,
                        pinned=[0, free + 1])
    omega = 2 * np.sqrt(k / m) * np.sin(mode * np.pi / (2 * (free + 1)))
    return Scene(parts=(net,), gravity=(0.0, 0.0, 0.0)), omega


def membrane_mode(free=4, k=100.0, m=0.01, amp=0.01, p=1, q=2):
    """(free + 2)^2 grid in the x-y plane, boundary ring pinned, zero rest length, z mode (p, q)."""
    n = free + 2
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    shape = np.sin(p * np.pi * i / (n - 1)) * np.sin(q * np.pi * j / (n - 1))
    x = np.stack([i / (n - 1), j / (n - 1), amp * shape], axis=-1).reshape(-1, 3)
    ids = np.arange(n * n).reshape(n, n)
    edges = np.vstack([np.c_[ids[:-1].ravel(), ids[1:].ravel()],
                       np.c_[ids[:, :-1].ravel(), ids[:, 1:].ravel()]])
    ring = np.flatnonzero((i == 0) | (j == 0) | (i == n - 1) | (j == n - 1))
    net = SpringNetwork(positions=x, masses=m, edges=edges, stiffness=k, rest_length=0.0,
                        pinned=ring)
    half_angle = np.array([p, q]) * np.pi / (2 * (n - 1))
    omega = 2 * np.sqrt(k / m) * np.sqrt(np.sum(np.sin(half_angle) ** 2))
    return Scene(parts=(net,), gravity=(0.0, 0.0, 0.0)), omega


def small_cloth(side=4, spacing=0.1, pretension=1.0):
    """side x side grid in the x-z plane hanging from its two top corners: structural and
    shear springs with damping (rest length = initial length / pretension), gravity, drag;
    free nodes start moving at (0.1, 0.2, 0) m/s."""
    i, j = np.meshgrid(np.arange(side), np.arange(side), indexing="ij")  # i: x, j: down
    x = np.stack([i * spacing, 0 * i, -j * spacing], axis=-1).reshape(-1, 3).astype(float)
    ids = np.arange(side * side).reshape(side, side)
    edges = np.vstack([np.c_[ids[:-1].ravel(), ids[1:].ravel()],
                       np.c_[ids[:, :-1].ravel(), ids[:, 1:].ravel()],
                       np.c_[ids[:-1, :-1].ravel(), ids[1:, 1:].ravel()],
                       np.c_[ids[1:, :-1].ravel(), ids[:-1, 1:].ravel()]])
    pinned = [ids[0, 0], ids[-1, 0]]
    velocities = np.tile([0.1, 0.2, 0.0], (side * side, 1))
    velocities[pinned] = 0.0
    rest = np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1) / pretension
    net = SpringNetwork(positions=x, masses=0.02, edges=edges, stiffness=200.0, damping=0.05,
                        rest_length=rest, velocities=velocities, pinned=pinned)
    return Scene(parts=(net,), gravity=G, linear_drag=0.01)


def _force_scale(scene, x, v) -> float:
    """max over nodes of the sum of the force terms' magnitudes over the mass (module doc)."""
    net = scene.part(SpringNetwork)
    i, j = net.edges.T
    d = np.linalg.norm(x[i] - x[j], axis=1)
    term = net.stiffness * (d + net.rest_length) + \
        net.damping * np.linalg.norm(v[i] - v[j], axis=1)
    total = np.bincount(i, term, len(net)) + np.bincount(j, term, len(net))
    total += net.masses * np.linalg.norm(scene.gravity) + \
        scene.linear_drag * np.linalg.norm(v, axis=1)
    return float(np.max(total / net.masses))


def _run_both(scene, dt, integrator, steps):
    a, b = REF.build(scene, dt, integrator), MJ.build(scene, dt, integrator)
    a.step(steps)
    b.step(steps)
    assert b.failure is None
    return a.observe(), b.observe()


# -- agreement with the in-house engine -------------------------------------------------------
@pytest.mark.parametrize("integrator", ["symplectic_euler", "rk4"])
@pytest.mark.parametrize("make, dt", [(hanging_chain, 1e-3), (small_cloth, 1e-3),
                                      (lambda: string_mode()[0], 1e-3),
                                      (lambda: membrane_mode()[0], 1e-3)])
def test_same_step_as_refsim_to_round_off(make, dt, integrator):
    scene, steps = make(), 50
    ref, got = _run_both(scene, dt, integrator, steps)
    net = scene.part(SpringNetwork)
    scale = max(_force_scale(scene, net.positions, net.velocities),
                _force_scale(scene, ref["x"], ref["v"]))
    c = ROUNDINGS * STAGES[integrator] * EPS * steps
    x_size, v_size = np.abs(ref["x"]).max(), np.abs(ref["v"]).max()
    assert np.abs(got["x"] - ref["x"]).max() <= c * (x_size + steps * dt * dt * scale)
    assert np.abs(got["v"] - ref["v"]).max() <= c * (dt * scale + v_size)
    assert np.abs(ref["x"] - net.positions).max() > 1e3 * c * x_size  # it moved


def test_pinned_nodes_stay_and_observation_contract():
    scene = small_cloth()
    sim = MJ.build(scene, 1e-3, "symplectic_euler")
    sim.step(20)
    obs = sim.observe()
    assert check_observation(obs, scene) == []
    pinned = scene.part(SpringNetwork).pinned
    assert np.array_equal(obs["x"][pinned], scene.part(SpringNetwork).positions[pinned])
    assert not obs["v"][pinned].any()


# -- exact normal modes -----------------------------------------------------------------------
def _step_matrix(integrator, omega, h) -> np.ndarray:
    """The 2x2 map (z, w) -> next of one step on z'' = -omega^2 z (exact discrete oracle)."""
    a = np.array([[0.0, 1.0], [-omega ** 2, 0.0]])
    if integrator == "symplectic_euler":  # kick then drift
        return np.array([[1.0 - (omega * h) ** 2, h], [-omega ** 2 * h, 1.0]])
    ha = h * a
    return np.eye(2) + ha + ha @ ha / 2 + ha @ ha @ ha / 6 + ha @ ha @ ha @ ha / 24


@pytest.mark.parametrize("integrator", ["symplectic_euler", "rk4"])
@pytest.mark.parametrize("make", [string_mode, membrane_mode])
def test_normal_mode_is_the_exact_discrete_oscillation(make, integrator):
    """A zero-rest-length network is linear and its z motion decouples: the mode keeps its shape
    and its amplitude follows the step's 2x2 map exactly. Bound: the map is neutrally stable
    (|eigenvalues| <= 1, eigenvector condition 1/cos(theta/2) < 1.01 here), so the local
    round-off ROUNDINGS eps |z| per step adds up linearly: N ROUNDINGS stages eps amp."""
    scene, omega = make()
    h, steps = 2 * np.pi / omega / 200, 200  # one period
    z0 = scene.part(SpringNetwork).positions[:, 2]
    sim = MJ.build(scene, h, integrator)
    step, state = _step_matrix(integrator, omega, h), np.array([1.0, 0.0])
    worst = 0.0
    for _ in range(4):
        sim.step(steps // 4)
        for _ in range(steps // 4):
            state = step @ state
        worst = max(worst, np.abs(sim.observe()["x"][:, 2] - z0 * state[0])
                    .max())
    assert worst <= steps * ROUNDINGS * STAGES[integrator] * EPS * np.abs(z0).max()


@pytest.mark.parametrize("make", [string_mode, membrane_mode])
def test_mode_frequency_is_omega_n(make):
    """RK4 at omega h = 2 pi / 200 against the continuous mode z0 cos(omega_n t) over one period:
    RK4's amplification R(i y) = exp(i y) (1 + O(y^5)) misses the phase by y^5 / 120 and the
    modulus by y^6 / 144 per step, so the error is <= N (y^5 / 120 + y^6 / 144) amp."""
    scene, omega = make()
    h, steps = 2 * np.pi / omega / 200, 200
    y = omega * h
    sim = MJ.build(scene, h, "rk4")
    sim.step(steps)
    z0 = scene.part(SpringNetwork).positions[:, 2]
    error = np.abs(sim.observe()["x"][:, 2] - z0 * np.cos(omega * steps * h)).max()
    assert error <= steps * (y ** 5 / 120 + y ** 6 / 144) * np.abs(z0).max()


# -- MuJoCo's own discrete step ---------------------------------------------------------------
def _partial_k_step(scene, x, v, h, deadband=True):
    """(M + h D + h^2 K) a = f - h K v with K = sum k u u^T and D = sum c u u^T + c_air I only:
    the step MuJoCo's `discrete` takes (no geometric stiffness), on the free nodes; with
    `deadband`, a tendon exactly at its rest length adds no stiffness (MuJoCo's closed
    springlength deadband [L0, L0]). Returns (a of the free nodes flat, cond(M_hat))."""
    net = scene.part(SpringNetwork)
    free = np.ones(len(net), bool)
    free[net.pinned] = False
    index = np.cumsum(free) - 1
    i, j = net.edges.T
    d = x[i] - x[j]
    length = np.linalg.norm(d, axis=1)
    u = d / length[:, None]
    v = np.where(free[:, None], v, 0.0)  # pinned nodes never move
    rate = np.sum((v[i] - v[j]) * u, axis=1)
    f_edge = -(net.stiffness * (length - net.rest_length) + net.damping * rate)[:, None] * u
    force = np.zeros_like(x)
    np.add.at(force, i, f_edge)
    np.add.at(force, j, -f_edge)
    force += net.masses[:, None] * np.asarray(scene.gravity) - scene.linear_drag * v
    uu = np.einsum("ea,eb->eab", u, u)

    def assemble(coef):
        rows, cols, vals = [], [], []
        for p, q, sign in ((i, i, 1), (j, j, 1), (i, j, -1), (j, i, -1)):
            keep = free[p] & free[q]
            r = 3 * index[p[keep]][:, None, None] + np.arange(3)[None, :, None]
            c = 3 * index[q[keep]][:, None, None] + np.arange(3)[None, None, :]
            vals.append((sign * coef[keep, None, None] * uu[keep]).ravel())
            rows.append(np.broadcast_to(r, uu[keep].shape).ravel())
            cols.append(np.broadcast_to(c, uu[keep].shape).ravel())
        n = 3 * free.sum()
        return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows),
                                                     np.concatenate(cols))), (n, n)).toarray()

    outside = (length != net.rest_length) if deadband else np.ones(len(length), bool)
    stiff, damp = assemble(net.stiffness * outside), assemble(net.damping)
    damp += scene.linear_drag * np.eye(len(damp))
    mass = np.diag(np.repeat(net.masses[free], 3))
    metric = mass + h * damp + h * h * stiff
    accel = np.linalg.solve(metric, force[free].ravel() - h * stiff @ v[free].ravel())
    return accel, np.linalg.cond(metric)


@pytest.mark.parametrize("make, dt", [(hanging_chain, 1e-3), (lambda: string_mode()[0], 1e-2),
                                      (lambda: small_cloth(pretension=1.02), 1e-3)])
def test_discrete_is_backward_euler_without_geometric_stiffness(make, dt):
    """One step of `discrete` equals the partial-K linearised backward Euler replica to
    cond(M_hat) ROUNDINGS eps |a| h (a direct Cholesky/Newton solve of that system, no
    constraints), and differs from refsim's Baraff-Witkin (full Jacobian) by far more."""
    scene = make()
    net = scene.part(SpringNetwork)
    accel, cond = _partial_k_step(scene, net.positions, net.velocities, dt)
    sim = MJ.build(scene, dt, "discrete")
    sim.step(1)
    free = np.ones(len(net), bool)
    free[net.pinned] = False
    dv = sim.observe()["v"][free].ravel() - net.velocities[free].ravel()
    bound = cond * ROUNDINGS * EPS * np.abs(accel).max() * dt
    assert np.abs(dv - dt * accel).max() <= bound
    bw = REF.build(scene, dt, "baraff_witkin")
    bw.step(1)
    assert np.abs(bw.observe()["v"] - sim.observe()["v"]).max() > 1e3 * bound


def test_discrete_drops_the_stiffness_of_a_tendon_exactly_at_rest():
    """A tendon whose length equals its springlength sits in the closed deadband [L0, L0] of
    MuJoCo's two-value springlength, where its stiffness is 0 in the discrete metric: the cloth
    at rest (every edge at its initial length; axis and 45-degree edges, whose lengths numpy
    and MuJoCo round alike) steps as the replica without K (same bound as above), far from the
    replica with K. Euler and RK4 are unaffected (the force is 0 either way)."""
    cloth = small_cloth()
    net = cloth.part(SpringNetwork)
    still = SpringNetwork(positions=net.positions, masses=net.masses, edges=net.edges,
                          stiffness=net.stiffness, damping=net.damping, pinned=net.pinned)
    scene = Scene(parts=(still,), gravity=G)
    h = 1e-3
    accel, cond = _partial_k_step(scene, still.positions, still.velocities, h)
    with_k, _ = _partial_k_step(scene, still.positions, still.velocities, h, deadband=False)
    sim = MJ.build(scene, h, "discrete")
    sim.step(1)
    free = np.ones(len(net), bool)
    free[net.pinned] = False
    dv = sim.observe()["v"][free].ravel()
    bound = cond * ROUNDINGS * EPS * np.abs(accel).max() * h
    assert np.abs(dv - h * accel).max() <= bound
    assert np.abs(dv - h * with_k).max() > 1e3 * bound


# -- refusals, settings, failures -------------------------------------------------------------
def test_refusals_name_the_reason():
    scene = hanging_chain()
    assert MJ.supports(scene, "symplectic_euler") is None
    assert "Verlet" in MJ.supports(scene, "velocity_verlet")
    assert "discrete" in MJ.supports(scene, "baraff_witkin")
    with pytest.raises(ValueError):
        MJ.build(scene, 1e-3, "baraff_witkin")
    net = scene.part(SpringNetwork)
    hair = SpringNetwork(positions=net.positions, masses=0.1, edges=net.edges, stiffness=500.0,
                         hinges=np.c_[np.arange(9), np.arange(1, 10), np.arange(2, 11)],
                         hinge_stiffness=0.1, pinned=[0, 1])
    assert "hinges" in MJ.supports(Scene(parts=(hair,), gravity=G), "rk4")
    two = Scene(parts=(net, net), gravity=G)
    assert "one network" in MJ.supports(two, "rk4")


def test_settings_declare_the_model():
    sim = MJ.build(hanging_chain(), 1e-3, "discrete")
    s = json.loads(json.dumps(jsonable(sim.settings())))
    assert s["integrator"]["native"] == "mjINT_DISCRETE"
    assert s["tendons"] == 10 and s["free_nodes"] == 9 and s["joint_damping"] == 0.05
    assert "geometric stiffness" in s["integrator"]["treated_implicitly"]
    assert s["eulerdamp"].startswith("disabled")


def test_divergence_is_a_failure():
    """Euler far past its limit omega h = 2 (stiffest edge): MuJoCo's bad-qacc/qvel warnings
    become Sim.failure (auto-reset off) instead of a silent reset."""
    scene, omega = string_mode(k=1e6)
    sim = MJ.build(scene, 10 / omega, "symplectic_euler")
    sim.step(2000)
    assert sim.failure is not None and "mujoco reported" in sim.failure
