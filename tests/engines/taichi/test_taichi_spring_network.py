"""taichi's spring-network group against refsim's (the same model and steppers): a
pretensioned zero-rest-length string in its first mode, a damped hanging chain under gravity
and drag, a small damped cloth pinned at its top corners; every stepper and both Baraff-Witkin
formulations; refusals, formulations offered and settings.

Round-off bounds (stated once, used throughout). One step of an explicit stepper here is, per
node, a chain of at most K = 64 roundings (a spring force is ~12 roundings, a cloth node sums
at most 8 springs; RK4 adds four stages and the weighted sums), in the same order as refsim's
(forces summed per node in refsim's order: the runs are in fact bit-identical on x86-64).
Every dt below is inside the stepper's stability interval (h omega_max <= 0.6 < 2), so the
step is non-expansive and the differences of k steps add: |dx| <= k K eps S_x. A round-off dx
becomes a velocity change of at most omega_max dx, so v carries S_v + omega_max S_x, with
omega_max^2 = max_i sum_s 2 k_s / m_i (Gershgorin on M^-1 K, |K_s| <= k_s ... (1 + L0/|d|)
bounded by 2 k_s while no spring is compressed to under half its rest length).
Baraff-Witkin solves (M - h D - h^2 K) dv = b: a backward-stable solve (taichi's LDLT,
SuperLU, LAPACK) differs from another by at most cond(A) K eps |dv|, so the explicit bound is
multiplied by cond(A) (computed from refsim's Jacobians at the start and at the end of the run,
the larger). CG stops at |r| < rtol |b|: two such solutions differ by at most
2 rtol cond(A) |dv|_2 <= 2 rtol cond(A) sqrt(3 n) max|dv| per step (in v, and h times that in
x), summed over the steps.
"""
import numpy as np
import pytest

from refsim_adapters.common.spring_network import NETWORK_INTEGRATORS
from refsim import registry
from refsim.models.spring_network import NetworkSystem
from refsim.scene import Scene, SpringNetwork

pytest.importorskip("taichi")
EPS = np.finfo(float).eps
K = 64  # roundings per node per step at most (module docstring)
TAICHI, REFSIM = registry.get_engine("taichi"), registry.get_engine("refsim")
EXPLICIT = ("symplectic_euler", "velocity_verlet", "rk4")
DT, STEPS = 1e-3, 150


def string_scene(free=12, tension_k=50.0, mass=0.01, amplitude=0.01):
    """Zero-rest-length string along x, ends pinned, first transverse (z) mode, no gravity."""
    x = np.zeros((free + 2, 3))
    x[:, 0] = np.linspace(0.0, 1.0, free + 2)
    x[1:-1, 2] = amplitude * np.sin(np.pi * np.arange(1, free + 1) / (free + 1))
    edges = np.c_[np.arange(free + 1), np.arange(1, free + 2)]
    net = SpringNetwork(positions=x, masses=mass, edges=edges, stiffness=tension_k,
                        rest_length=0.0, pinned=[0, free + 1])
    return Scene(parts=(net,), gravity=(0, 0, 0))


def chain_scene(links=10):
    """Chain in the x-z plane, both ends pinned at z = 0, rest length 0.1 m over a 0.8 m span
    (it sags), edge damping and air drag, gravity."""
    x = np.zeros((links + 1, 3))
    x[:, 0] = np.linspace(0.0, 0.8, links + 1)
    edges = np.c_[np.arange(links), np.arange(1, links + 1)]
    net = SpringNetwork(positions=x, masses=0.1, edges=edges, stiffness=200.0,
                        rest_length=0.1, damping=0.5, pinned=[0, links])
    return Scene(parts=(net,), gravity=(0, 0, -9.81), linear_drag=0.05)


def cloth_scene(side=6):
    """side x side cloth in the x-z plane, structural + shear springs, top corners pinned;
    34 free nodes at side 6: a state of 102 >= 96 entries, so both engines offer "cg"."""
    row, col = np.meshgrid(np.arange(side), np.arange(side), indexing="ij")
    idx = row * side + col
    x = np.c_[0.1 * col.ravel(), np.zeros(side * side), -0.1 * row.ravel()]
    edges = np.vstack([np.c_[idx[:, :-1].ravel(), idx[:, 1:].ravel()],
                       np.c_[idx[:-1, :].ravel(), idx[1:, :].ravel()],
                       np.c_[idx[:-1, :-1].ravel(), idx[1:, 1:].ravel()],
                       np.c_[idx[:-1, 1:].ravel(), idx[1:, :-1].ravel()]])
    net = SpringNetwork(positions=x, masses=0.01, edges=edges, stiffness=100.0, damping=0.02,
                        pinned=[0, side - 1])
    return Scene(parts=(net,), gravity=(0, 0, -9.81), linear_drag=0.01)


SCENES = {"string": string_scene, "chain": chain_scene, "cloth": cloth_scene}


def omega_max(scene):
    """Gershgorin bound of sqrt(|M^-1 K|): max_i sqrt(sum_s 2 k_s / m_i)."""
    net = scene.part(SpringNetwork)
    per_node = np.zeros(len(net))
    np.add.at(per_node, net.edges.ravel(), np.repeat(2.0 * net.stiffness, 2))
    return float(np.sqrt(np.max(per_node / net.masses)))


def bw_condition(scene, states):
    """cond_2(M - h D - h^2 K) from refsim's Jacobians, the largest over `states` (x, v)."""
    system = NetworkSystem(scene.part(SpringNetwork), scene.gravity, scene.linear_drag)
    m = np.repeat(system.masses, 3)
    conds = []
    for x, v in states:
        kx, kv = system.sparse_force_jacobians(0.0, x[system.free].ravel(),
                                               v[system.free].ravel())
        conds.append(np.linalg.cond(np.diag(m) - DT * kv.toarray() - DT * DT * kx.toarray()))
    return max(conds)


def run_pair(scene, integrator, variant=""):
    """(taichi observations, refsim observations) after STEPS steps, in three calls."""
    out = []
    for engine in (TAICHI, REFSIM):
        sim = engine.build(scene, DT, integrator, variant)
        for n in (1, STEPS // 2 - 1, STEPS - STEPS // 2):
            sim.step(n)
        assert sim.failure is None, sim.failure
        out.append(sim.observe())
        sim.close()
    return out


def bounds(scene, obs, factor):
    s_x = np.max(np.abs(obs["x"]))
    s_v = np.max(np.abs(obs["v"])) + omega_max(scene) * s_x
    return STEPS * K * EPS * factor * s_x, STEPS * K * EPS * factor * s_v


@pytest.mark.parametrize("integrator", EXPLICIT)
@pytest.mark.parametrize("name", sorted(SCENES))
def test_explicit_steppers_match_refsim(name, integrator):
    scene = SCENES[name]()
    assert omega_max(scene) * DT <= 0.6  # inside every explicit stability interval
    ours, theirs = run_pair(scene, integrator)
    bx, bv = bounds(scene, theirs, 1.0)
    assert np.max(np.abs(ours["x"] - theirs["x"])) <= bx
    assert np.max(np.abs(ours["v"] - theirs["v"])) <= bv
    assert np.max(np.abs(theirs["x"] - SCENES[name]().part(SpringNetwork).positions)) > 1e3 * bx


@pytest.mark.parametrize("name", sorted(SCENES))
def test_baraff_witkin_direct_matches_refsim(name):
    scene = SCENES[name]()
    ours, theirs = run_pair(scene, "baraff_witkin", "")
    net = scene.part(SpringNetwork)
    cond = bw_condition(scene, [(net.positions, net.velocities), (theirs["x"], theirs["v"])])
    bx, bv = bounds(scene, theirs, cond)
    assert np.max(np.abs(ours["x"] - theirs["x"])) <= bx
    assert np.max(np.abs(ours["v"] - theirs["v"])) <= bv


def test_baraff_witkin_cg_matches_refsim_cg():
    scene = cloth_scene()
    assert TAICHI.formulations(scene) == ("", "cg") == REFSIM.formulations(scene)
    ours, theirs = run_pair(scene, "baraff_witkin", "cg")
    # max |dv| per step from refsim's direct steps (the same dv to far below this bound)
    sim = REFSIM.build(scene, DT, "baraff_witkin", "")
    dv_max, v_prev = 0.0, sim.observe()["v"]
    for _ in range(STEPS):
        sim.step(1)
        v = sim.observe()["v"]
        dv_max, v_prev = max(dv_max, np.max(np.abs(v - v_prev))), v
    net = scene.part(SpringNetwork)
    cond = bw_condition(scene, [(net.positions, net.velocities), (theirs["x"], theirs["v"])])
    per_step = 2 * 1e-10 * cond * np.sqrt(3 * (len(net) - 2)) * dv_max
    bx, bv = bounds(scene, theirs, cond)
    assert np.max(np.abs(ours["v"] - theirs["v"])) <= STEPS * per_step + bv
    # the v differences j per_step after step j move x by h j per_step: at most h STEPS^2
    assert np.max(np.abs(ours["x"] - theirs["x"])) <= DT * STEPS ** 2 * per_step + bx


def test_string_mode_is_exact_under_baraff_witkin():
    """Zero rest length, no damping: forces are linear, so a normal mode stays a mode and
    Baraff-Witkin (backward Euler here) scales its (x, v) by the exact 2x2 map per step."""
    scene, free = string_scene(), 12
    sim = TAICHI.build(scene, DT, "baraff_witkin", "")
    sim.step(STEPS)
    k, m = 50.0, 0.01
    w2 = (4 * k / m) * np.sin(np.pi / (2 * (free + 1))) ** 2  # first mode of the chain
    step = np.linalg.inv(np.array([[1.0, -DT], [DT * w2, 1.0]]))  # (x, v) backward Euler
    amp = np.linalg.matrix_power(step, STEPS) @ np.array([1.0, 0.0])
    shape = 0.01 * np.sin(np.pi * np.arange(1, free + 1) / (free + 1))
    obs = sim.observe()
    cond = 1 + DT * DT * 4 * k / m  # A = M - h^2 K, eigenvalues in [m, m (1 + 4 h^2 k/m)]
    bx, bv = bounds(scene, obs, cond)
    assert np.max(np.abs(obs["x"][1:-1, 2] - amp[0] * shape)) <= bx
    assert np.max(np.abs(obs["v"][1:-1, 2] - amp[1] * shape)) <= bv
    assert np.max(np.abs(obs["x"][:, :2] - scene.part(SpringNetwork).positions[:, :2])) <= bx
    assert 1 - np.hypot(amp[0], amp[1] / np.sqrt(w2)) > 1e6 * bx  # the damping is visible


def test_pinned_nodes_stay_and_observation_has_every_node():
    scene = chain_scene()
    sim = TAICHI.build(scene, DT, "symplectic_euler", "")
    sim.step(20)
    obs = sim.observe()
    net = scene.part(SpringNetwork)
    assert obs["x"].shape == obs["v"].shape == (len(net), 3)
    assert np.array_equal(obs["x"][net.pinned], net.positions[net.pinned])
    assert not obs["v"][net.pinned].any()


def test_refusals_and_formulations():
    chain = chain_scene()
    assert TAICHI.offered_integrators(chain) == NETWORK_INTEGRATORS
    assert TAICHI.formulations(chain) == ("",)  # 27 entries: refsim solves densely, no "cg"
    net = chain.part(SpringNetwork)
    bent = SpringNetwork(positions=net.positions, masses=net.masses, edges=net.edges,
                         stiffness=net.stiffness, hinges=[[0, 1, 2]], hinge_stiffness=1.0,
                         pinned=net.pinned)
    bent_scene = Scene(parts=(bent,), gravity=(0, 0, -9.81))
    reason = TAICHI.supports(bent_scene, "baraff_witkin")  # bending: explicit steppers only
    assert reason is not None and "hinge" in reason
    assert TAICHI.supports(bent_scene, "rk4") is None
    assert "integrator" in TAICHI.supports(chain, "leapfrog")
    with pytest.raises(ValueError, match="formulation"):
        TAICHI.build(chain, DT, "baraff_witkin", "cg")


@pytest.mark.parametrize("variant", ["", "cg"])
def test_settings_state_solver_and_precision(variant):
    sim = TAICHI.build(cloth_scene(), DT, "baraff_witkin", variant)
    sim.step(2)
    out = sim.settings()
    assert out["dtype"] == "float64" and out["default_fp"].endswith("f64")
    assert out["threads"] == out["cpu_max_num_threads"] >= 1
    assert ("LDLT" in out["solve"]) if variant == "" else (out["cg_rtol"] == 1e-10 and
                                                          out["cg_iterations_last_step"] > 0)
    assert out["model"]["free_nodes"] == 34 and out["model"]["terms"] == ["stretch"]


def test_cg_failure_is_reported():
    """A CG cap of zero iterations cannot reach the tolerance: the Sim fails with a reason."""
    from refsim_adapters.taichi_engine.groups import spring_network as group
    sim = TAICHI.build(cloth_scene(), DT, "baraff_witkin", "cg")
    saved = group.CG_MAXITER_PER_DOF
    group.CG_MAXITER_PER_DOF = 0
    try:
        sim.step(1)
    finally:
        group.CG_MAXITER_PER_DOF = saved
    assert sim.failure is not None and "CG" in sim.failure and sim.steps == 0
