"""NetworkSystem (refsim/models/spring_network.py): a SpringNetwork on its free nodes.

Checked against formulas written here from the model's definition (not from the code): the
stretch/drag/bending forces on the free nodes, their sparse Jacobians against central
differences, the dense Jacobians against the sparse ones, Baraff-Witkin's sparse solves against
its dense solve, velocity Verlet's energy error order, and pinned nodes that never move.
"""
from __future__ import annotations

import numpy as np
import pytest

import refsim.integrators.implicit as implicit
from refsim.integrators import BaraffWitkin, get_integrator
from refsim.models.bending import bending_terms
from refsim.models.spring_network import NetworkSystem, kinetic_energy, network_potential
from refsim.registry import get_engine
from refsim.scene import Scene, SpringNetwork

EPS = np.finfo(float).eps
G = np.array([0.0, 0.0, -9.81])


def _network(seed=0, damping=0.3, bending=True) -> SpringNetwork:
    """A 3 x 4 sheet, jittered out of its plane, with a diagonal, an edge between the two
    pinned nodes (it must drop out), hinges along the rows and dihedrals across the diagonals."""
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(3), np.arange(4), indexing="ij")
    idx = i * 4 + j
    x = np.c_[0.3 * j.ravel(), 0.1 * rng.standard_normal(12), -0.3 * i.ravel()]
    edges = np.vstack([np.c_[idx[:, :-1].ravel(), idx[:, 1:].ravel()],
                       np.c_[idx[:-1, :].ravel(), idx[1:, :].ravel()],
                       np.c_[idx[:-1, :-1].ravel(), idx[1:, 1:].ravel()], [[0, 3]]])
    extra = {}
    if bending:
        extra = dict(hinges=np.c_[idx[:, :-2].ravel(), idx[:, 1:-1].ravel(), idx[:, 2:].ravel()],
                     hinge_stiffness=0.05,
                     dihedrals=np.c_[idx[:-1, 1:].ravel(), idx[:-1, :-1].ravel(),
                                     idx[1:, 1:].ravel(), idx[1:, :-1].ravel()],
                     dihedral_stiffness=0.02)
    velocities = 0.2 * rng.standard_normal((12, 3))
    velocities[[0, 3]] = 0.0  # pinned
    return SpringNetwork(positions=x, masses=0.05 + 0.01 * rng.random(12), edges=edges,
                         stiffness=40.0 + rng.random(len(edges)),
                         rest_length=0.28 + 0.02 * rng.random(len(edges)),
                         damping=damping, velocities=velocities,
                         pinned=[0, 3], **extra)


def _forces_by_definition(net, x_full, v_full, drag):
    """Forces on every node from the module's formulas, node by node (pinned rows included)."""
    f = np.zeros_like(x_full)
    for (a, b), k, rest, c in zip(net.edges, net.stiffness, net.rest_length, net.damping):
        d = x_full[a] - x_full[b]
        u = d / np.linalg.norm(d)
        fa = -(k * (np.linalg.norm(d) - rest) + c * np.dot(v_full[a] - v_full[b], u)) * u
        f[a] += fa
        f[b] -= fa
    for term in bending_terms(net):
        f += term.forces(x_full)
    return f - drag * v_full


def _state(system, net):
    return net.positions[system.free].ravel(), net.velocities[system.free].ravel()


def test_forces_on_free_nodes_follow_the_definition():
    """Edges to a pinned node act as anchors, the pinned-pinned edge exerts nothing on the
    state: the free rows equal the definition to 64 eps of the largest force term."""
    net = _network()
    system = NetworkSystem(net, G, drag=0.4)
    x, v = _state(system, net)
    got = system.forces(x, v)
    want = _forces_by_definition(net, net.positions, net.velocities, 0.4)[system.free]
    scale = np.max(net.stiffness) * np.max(np.linalg.norm(net.positions, axis=1))
    assert np.max(np.abs(got - want)) <= 64 * EPS * scale
    assert len(system.springs.body) == len(net.edges) - 1  # the (0, 3) edge is not an edge here


def test_a_pinned_node_must_start_at_rest():
    net = _network()
    moving = np.array(net.velocities)
    moving[0] = [0.0, 0.1, 0.0]
    with pytest.raises(ValueError, match="network.velocities of pinned nodes"):
        SpringNetwork(positions=net.positions, masses=net.masses, edges=net.edges,
                      stiffness=net.stiffness, velocities=moving, pinned=net.pinned)


def test_sparse_jacobians_equal_central_differences():
    """df/dx and df/dv against central differences at h and h/2: the gap is at most the
    Richardson estimate of the truncation (D(h) - D(h/2)) / 3 twice over, plus round-off
    8 eps |f| / (h/2). At v = 0 for df/dx: Baraff & Witkin's K leaves out the x-derivative of
    the damping force's direction (sec. 4.2; spring_jacobians), which vanishes there; df/dv
    (the force is linear in v) at a moving state."""
    net = _network(seed=1)
    system = NetworkSystem(net, G, drag=0.4)
    x, v = _state(system, net)
    kx, _ = system.sparse_force_jacobians(0.0, x, np.zeros_like(v))
    _, kv = system.sparse_force_jacobians(0.0, x, v)
    fmax = np.max(np.abs(system.forces(x, v)))

    def central(fn, base, h):
        eye = np.eye(base.size) * h
        return np.stack([(fn(base + e) - fn(base - e)).ravel() / (2 * h) for e in eye], axis=1)

    for matrix, fn, base in ((kx, lambda y: system.forces(y, np.zeros_like(v)), x),
                             (kv, lambda w: system.forces(x, w), v)):
        h = 1e-4
        coarse, fine = central(fn, base, h), central(fn, base, h / 2)
        bound = 2 * np.abs(coarse - fine) / 3 + 16 * EPS * fmax / h
        assert np.all(np.abs(matrix.toarray() - fine) <= bound + 1e-12 * np.abs(fine))


def test_dense_jacobians_are_the_sparse_ones_over_the_masses():
    net = _network(seed=2)
    system = NetworkSystem(net, G, drag=0.1)
    x, v = _state(system, net)
    kx, kv = system.sparse_force_jacobians(0.0, x, v)
    ax, av = system.jacobians(0.0, x, v)
    inv_m = np.repeat(1.0 / system.masses, 3)[:, None]
    # same operations: jacobians() returns inv_m * kx.toarray(), this product
    assert np.array_equal(ax, inv_m * kx.toarray())
    assert np.array_equal(av, inv_m * kv.toarray())


@pytest.mark.parametrize("solver", ["direct", "cg"])
def test_baraff_witkin_sparse_solves_equal_the_dense_solve(monkeypatch, solver):
    """The same step three ways on a 10-free-node network with bending (30 entries: below the
    sparse threshold, which is lowered here): the symmetric sparse system solved by SuperLU
    or CG (rtol 1e-12) equals the dense solve of the system divided by the masses, to
    cond(A) x 64 eps (direct) or 4 cond(A) rtol (CG) of |dv|."""
    net = _network(seed=3)
    system = NetworkSystem(net, G, drag=0.2)
    x, v = _state(system, net)
    h = 5e-3
    dense = BaraffWitkin().step(system, 0.0, (x, v), h)
    monkeypatch.setattr(implicit, "SPARSE_MIN", 1)
    sparse = BaraffWitkin(solver, rtol=1e-12).step(system, 0.0, (x, v), h)
    kx, kv = system.sparse_force_jacobians(0.0, x, v)
    m = np.repeat(system.masses, 3)
    cond = np.linalg.cond(np.diag(m) - h * kv.toarray() - h * h * kx.toarray())
    dv = np.max(np.abs(dense[1] - v))
    bound = cond * (64 * EPS if solver == "direct" else 4 * 1e-12) * dv
    assert np.max(np.abs(sparse[1] - dense[1])) <= bound
    assert np.max(np.abs(sparse[0] - dense[0])) <= h * bound


def _energy(net, system, x, v):
    return (network_potential(net, system.full_positions(x), G)
            + kinetic_energy(net, system.full_velocities(v)))


def test_velocity_verlet_energy_error_is_second_order():
    """Undamped network with bending: velocity Verlet's largest energy error over 0.5 s falls
    by 4 (+- 10 %, the h^4 term) when h halves (a symplectic second-order method: bounded,
    O(h^2) energy error)."""
    net = _network(seed=4, damping=0.0)
    system = NetworkSystem(net, G)
    stepper = get_integrator("velocity_verlet")
    errors = []
    for h in (2e-3, 1e-3):
        x, v = _state(system, net)
        e0, worst = _energy(net, system, x, v), 0.0
        state = stepper.start(system, 0.0, x, v, h)
        t = 0.0
        for _ in range(int(round(0.5 / h))):
            t, state = stepper.advance(system, t, state, h, 1)
            xo, vo = stepper.output(system, t, state, h)
            worst = max(worst, abs(_energy(net, system, xo, vo) - e0))
        errors.append(worst)
    assert errors[0] / errors[1] == pytest.approx(4.0, rel=0.1)


def test_pinned_nodes_never_move_and_are_observed():
    net = _network(seed=5)
    engine = get_engine("refsim")
    sim = engine.build(Scene(parts=(net,), gravity=G, linear_drag=0.1), 2e-3, "rk4", "")
    sim.step(50)
    out = sim.observe()
    assert out["x"].shape == (12, 3)
    assert np.array_equal(out["x"][net.pinned], net.positions[net.pinned])
    assert np.array_equal(out["v"][net.pinned], np.zeros((2, 3)))
    assert np.all(np.linalg.norm(out["x"] - net.positions, axis=1)[1:3] > 0)
