"""pybullet's fem group (one tetrahedral stable Neo-Hookean mesh as its deformable body): its
forces are refsim's neo_hookean forces, its undamped step is symplectic Euler on them with its
own (equal) node masses, its staged damped dynamics reaches refsim's static equilibrium, and
what differs from refsim's scene is measured: pybullet spreads the mass evenly over the nodes
(refsim lumps rho V / 4 per element node), and no load reaches a node. Facts in
adapters/pybullet_engine/fem_softbody.py.

Round-off (every bound below): pybullet and refsim compute the same forces by other operations
in another order (btMatrix3x3's inverse and cofactor, per-element accumulation), so they agree
to a few hundred ulps of the force scale, not bit for bit; a static solve's positions agree to
the forces' rounding through the stiffness (cases/fem/_static.py's bound).
"""
import numpy as np
import pybullet  # noqa: F401  (fail, never skip, without the engine)
import pytest

from refsim_adapters.pybullet_engine.fem_softbody import (TetFile, load_mesh,
                                                          neo_hookean_coefficients, node_masses)
from refsim_adapters.pybullet_engine.softbody import node_positions
from refsim_adapters.pybullet_engine.fem_vtk import write_vtk
from refsim_adapters.pybullet_engine.runtime import c_stdout_silenced
from refsim_cases.fem._static import ROUNDING_TERMS, free_stiffness_extremes
from refsim.models.fem.meshes import box_tetrahedra, rectangle_triangles
from refsim.models.fem.model import ElasticBody
from refsim.registry import get_case, get_engine
from refsim.scene import Material, Plasticity, Scene, TetMesh, TriangleMesh

ENGINE = get_engine("pybullet")
REFSIM = get_engine("refsim")
EPS = np.finfo(float).eps
G = (0.0, 0.0, -9.81)
FORCE_RTOL = 1e-12  # of the largest nodal force: ~4500 ulps for forces summed over a node's
#                     ~24 elements by other operations in another order (measured 1e-15..1e-14)


def bar(strain="neo_hookean", e=2e4, pinned="top", positions=None, loads=None, **mesh_kw):
    """A 0.2 x 0.2 x 1 m bar of 2 x 2 x 5 Kuhn cells (120 tetrahedra), nu = 0.3, rho = 100;
    pinned: its top face (z = 1, "top": hanging under gravity), both end faces ("ends") or
    none."""
    nodes, tets = box_tetrahedra(2, 2, 5, 0.2, 0.2, 1.0)
    top, bottom = nodes[:, 2] == 1.0, nodes[:, 2] == 0.0
    pins = np.flatnonzero({"top": top, "ends": top | bottom, "none": top & bottom}[pinned])
    return TetMesh(nodes, tets, Material(e, 0.3, 100.0, strain), pinned=pins,
                   positions=positions, loads=loads, **mesh_kw)


def rounding_bound(mesh, x):
    """The static cases' bound on a solve at round-off (cases/fem/_static.py): sqrt(dofs)
    ROUNDING_TERMS eps lambda_max max|x| / lambda_min of the free dofs' stiffness at x; it
    bounds the distance of any rounding-level equilibrium from the exact one, so twice it
    bounds two such solves' gap (3.7e-9 m for the bar at rest: its condition number 2.2e4)."""
    lam_min, lam_max = free_stiffness_extremes(mesh, x)
    dofs = 3 * (len(mesh) - len(mesh.pinned))
    return float(np.sqrt(dofs) * ROUNDING_TERMS * EPS * lam_max * np.abs(x).max() / lam_min)


def static_scene(mesh, gravity=G):
    return Scene(parts=(mesh,), gravity=gravity, meta={"solve": "static"})


def solve(engine, scene):
    sim = engine.build(scene, 1.0, "steady")
    try:
        sim.step(1)
        assert sim.failure is None, sim.failure
        return sim.observe()
    finally:
        sim.close()


@pytest.fixture
def client():
    with c_stdout_silenced():
        cid = pybullet.connect(pybullet.DIRECT)
    yield cid
    pybullet.disconnect(physicsClientId=cid)


def kicked(cid, mesh, x0, h, force_node=None):
    """pybullet's positions after one undamped step of h from x0 at rest (gravity off), and
    the same with a force of 1 kN applied to node `force_node` (applyExternalForce)."""
    tet_file = TetFile(mesh)
    try:
        body = load_mesh(pybullet, cid, mesh, tet_file, 0.0, (0.0, 0.0, 0.0), x0)
        pybullet.setPhysicsEngineParameter(fixedTimeStep=h, numSubSteps=0, physicsClientId=cid)
        if force_node is not None:
            pybullet.applyExternalForce(body, force_node, [1e3, 0, 0], [0, 0, 0],
                                        pybullet.WORLD_FRAME, physicsClientId=cid)
        pybullet.stepSimulation(physicsClientId=cid)
        return node_positions(pybullet, cid, body)
    finally:
        tet_file.cleanup()


def test_nodes_in_file_order_and_anchors_exact(client):
    mesh = bar()
    tet_file = TetFile(mesh)
    body = load_mesh(pybullet, client, mesh, tet_file, 0.0, G)
    assert np.array_equal(node_positions(pybullet, client, body), mesh.vertices)
    pybullet.setPhysicsEngineParameter(fixedTimeStep=1e-3, numSubSteps=0, physicsClientId=client)
    for _ in range(50):
        pybullet.stepSimulation(physicsClientId=client)
    x = node_positions(pybullet, client, body)
    tet_file.cleanup()
    assert np.array_equal(x[mesh.pinned], mesh.vertices[mesh.pinned])  # mass 0: never moves
    assert x[:, 2].min() < -1e-4  # the rest falls: the test would see a frozen body


@pytest.mark.parametrize("shape", ["homogeneous", "random"])
def test_forces_are_refsims_neo_hookean(client, shape):
    """One undamped step from rest: x1 = x0 + h^2 f(x0) / m, so pybullet's elastic force is
    m (x1 - x0) / h^2; it equals refsim's neo_hookean force (the same energy up to a constant)
    at a homogeneous stretch F = diag(1.2, 0.9, 1.05) and at random node offsets of 5 cm."""
    mesh = bar(pinned="none")
    x0 = mesh.vertices * np.array([1.2, 0.9, 1.05])
    if shape == "random":
        x0 = mesh.vertices + np.random.default_rng(3).uniform(-0.05, 0.05, mesh.vertices.shape)
    h = 1e-3  # moves nodes by up to 2 cm: far above the differencing round-off, no clamp
    x1 = kicked(client, mesh, x0, h)
    m = node_masses(mesh)[:, None]
    pb = m * (x1 - x0) / h ** 2
    ref = ElasticBody.of(mesh).forces(x0)
    scale = np.abs(ref).max()
    # differencing x1 - x0 rounds by eps |x| per coordinate: m 2 eps |x| / h^2 in the force
    differencing = float(m.max() * 2 * EPS * np.abs(x1).max() / h ** 2)
    err = np.abs(pb - ref).max()
    assert err <= FORCE_RTOL * scale + differencing, (err, scale, differencing)
    if shape == "homogeneous":  # interior nodes carry no force in a homogeneous field
        assert scale > 10.0


def test_node_forces_do_not_reach_the_deformable_world(client):
    """applyExternalForce on a soft-body node: the step is bit-identical without it."""
    mesh = bar(pinned="none")
    x0 = mesh.vertices * np.array([1.1, 1.0, 1.0])
    plain = kicked(client, mesh, x0, 1e-3)
    forced = kicked(client, mesh, x0, 1e-3, force_node=5)
    assert np.array_equal(plain, forced)
    assert np.abs(plain - x0).max() > 1e-6  # the elastic force did move the nodes


def symplectic_euler(mesh, gravity, h, steps):
    """refsim's neo_hookean forces stepped by kick-drift with pybullet's node masses (total /
    n, anchored nodes fixed): (x, v) after `steps` steps from the mesh's positions at rest."""
    model, free = ElasticBody.of(mesh), np.ones(len(mesh), bool)
    free[mesh.pinned] = False
    m = node_masses(mesh)[free, None]
    x, v = np.array(mesh.positions, float), np.zeros((len(mesh), 3))
    for _ in range(steps):
        v[free] += h * (model.forces(x)[free] / m + np.asarray(gravity))
        x[free] += h * v[free]
    return x, v


def test_undamped_step_is_symplectic_euler_on_pybullets_masses():
    """pybullet's deformable step without damping is kick (gravity + Neo-Hookean force at x_n)
    then drift: refsim's forces stepped so with the same node masses agree to round-off over
    200 steps of a hanging bar (it falls and stretches 3 cm); refsim's own group (lumped masses rho V / 4)
    differs by the mass distribution, which the agreement above shows is the whole cause."""
    scene = Scene(parts=(bar(),), gravity=G)
    h, steps = 1e-3, 200
    sim = ENGINE.build(scene, h, "symplectic_euler")
    sim.step(steps)
    pb = sim.observe()
    sim.close()
    x, v = symplectic_euler(bar(), G, h, steps)
    lumped = REFSIM.build(scene, h, "symplectic_euler")
    lumped.step(steps)
    gap_lumped = np.abs(lumped.observe()["x"] - pb["x"]).max()
    sag = np.abs(x - bar().positions).max()
    assert sag > 1e-3
    # x: two float64 force sums in another order (FORCE_RTOL of ~100 N) moved by h^2 / m
    # (2e-5 m/N) each step, summed over the steps' drift: ~1e-13 m; v = (x_n - x_{n-1}) / h
    # carries the two positions' bound and their differencing, 2 eps |x|, over h
    x_atol = 1e-13
    v_atol = 2 * (x_atol + EPS * np.abs(x).max()) / h
    np.testing.assert_allclose(pb["x"], x, rtol=0, atol=x_atol)
    np.testing.assert_allclose(pb["v"], v, rtol=0, atol=v_atol)
    assert gap_lumped > 1e4 * 1e-13  # the lumped masses move the bar measurably differently


def test_static_patch_test_within_the_cases_bound():
    """The tetrahedral Neo-Hookean patch test through the case's own error and bound (the
    static solve's bound at the in-house Newton's stop, 1e-12 of the force scale): pybullet's
    staged damped dynamics reaches the linear field to round-off."""
    case = get_case("patch_test")
    p = case.variant_params("tet_neo_hookean")
    obs = solve(ENGINE, case.scene(p))
    err = np.linalg.norm(obs["x"] - case.exact(p))
    bound = case.solve_bound(p)[0]
    assert err <= bound


def test_static_scene_at_rest_stays_put():
    """No gravity and every node at its rest position: pybullet's rest forces are rounding
    (its F = Ds Dm^-1 is I to a few ulps), so the nodes stay within the static solve's rounding
    bound (3.7e-9 m here); measured 1.4e-13 m."""
    mesh = bar()
    obs = solve(ENGINE, static_scene(mesh, gravity=(0.0, 0.0, 0.0)))
    assert np.abs(obs["x"] - mesh.vertices).max() <= rounding_bound(mesh, mesh.vertices)
    assert obs["iterations"] < 1000, obs["iterations"]


def test_static_stretched_bar_is_refsims_static_solve():
    """Both end faces pinned, the top one moved up 20 %, no gravity: no mass enters, so
    pybullet's equilibrium is refsim's static solve of the scene as stated, to the forces'
    rounding (the bar necks: no closed form, refsim's Newton solve is the reference)."""
    mesh = bar(pinned="ends")
    positions = np.array(mesh.vertices)
    positions[positions[:, 2] == 1.0, 2] = 1.2
    scene = static_scene(bar(pinned="ends", positions=positions), gravity=(0.0, 0.0, 0.0))
    pb, ref = solve(ENGINE, scene), solve(REFSIM, scene)
    interior = np.abs(ref["x"] - scene.parts[0].vertices * [1, 1, 1.2]).max()
    gap = np.abs(pb["x"] - ref["x"]).max()
    assert interior > 1e-3  # the free nodes do not follow the homogeneous stretch (necking)
    assert gap <= 2 * rounding_bound(scene.parts[0], ref["x"])  # measured 1e-16 m


@pytest.mark.parametrize("youngs", [2e4, pytest.param(2e3, marks=pytest.mark.slow)],
                         ids=["sag_2pct", "sag_28pct"])
def test_static_hanging_bar_is_refsims_equilibrium_with_pybullets_masses(youngs):
    """A bar hanging from its top face under gravity: pybullet's equilibrium is refsim's
    static Newton solve of the same law with pybullet's node masses as loads (m g on every
    node, total / n), to the forces' rounding; against refsim's scene as stated (lumped
    masses rho V / 4 per element node) it differs by the mass distribution alone."""
    mesh = bar(e=youngs)
    pb = solve(ENGINE, static_scene(mesh))
    loads = node_masses(mesh)[:, None] * np.array(G)
    same = solve(REFSIM, static_scene(bar(e=youngs, loads=loads), gravity=(0.0, 0.0, 0.0)))
    lumped = solve(REFSIM, static_scene(mesh))
    motion = np.abs(same["x"] - mesh.positions).max()
    gap, gap_lumped = np.abs(pb["x"] - same["x"]).max(), np.abs(pb["x"] - lumped["x"]).max()
    assert gap <= 2 * rounding_bound(mesh, same["x"])  # measured 2e-16 and 6e-16 m
    assert gap_lumped > 0.01 * motion  # measured 11 % and 4.7 % of the motion: no round-off


class _File:
    def __init__(self, path):
        self.path = str(path)


def test_one_flipped_tetrahedron_is_refused_and_would_explode(client, tmp_path):
    """pybullet weighs each tetrahedron by its signed rest volume (F is the same either way:
    swapping two nodes swaps the same columns of Ds and Dm), so a flipped one has negative
    stiffness. The writer refuses it; written anyway, a 6-tetrahedron cube hanging from its
    top face with tetrahedron 0's last two nodes swapped explodes within 100 steps of 1 ms
    (its correct twin sags 3 cm)."""
    nodes, tets = box_tetrahedra(1, 1, 1, 0.2, 0.2, 1.0)
    mesh = TetMesh(nodes, tets, Material(2e4, 0.3, 100.0, "neo_hookean"),
                   pinned=np.flatnonzero(nodes[:, 2] == 1.0))
    flipped = np.array(tets)
    flipped[0, [2, 3]] = flipped[0, [3, 2]]
    with pytest.raises(ValueError, match=r"tetrahedra \[0\] \(1 of 6\)"):
        write_vtk(tmp_path / "flipped.vtk", nodes, flipped)
    reach = {}
    for name, cells in (("flipped", flipped), ("correct", tets)):
        write_vtk(tmp_path / f"{name}.vtk", nodes, cells, check=False)
        body = load_mesh(pybullet, client, mesh, _File(tmp_path / f"{name}.vtk"), 0.0, G)
        pybullet.setPhysicsEngineParameter(fixedTimeStep=1e-3, numSubSteps=0,
                                           physicsClientId=client)
        for _ in range(100):
            pybullet.stepSimulation(physicsClientId=client)
        x = node_positions(pybullet, client, body)
        reach[name] = np.nan_to_num(np.abs(x - nodes).max(), nan=np.inf)
    assert reach["correct"] < 0.1  # measured 0.034 m
    assert reach["flipped"] > 1e3  # measured 2.3e4 m


@pytest.mark.parametrize("change, reason", [
    (lambda m: TriangleMesh(*rectangle_triangles(2, 2), Material(1e3, 0.3, 1.0, "neo_hookean"),
                            pinned=[0, 1, 2]), "no plane-stress or plane-strain element"),
    (lambda m: bar(strain="corotated"), "got strain 'corotated'"),
    (lambda m: TetMesh(m.vertices, m.tetrahedra, Material(
        2e4, 0.3, 100.0, "neo_hookean", Plasticity(1e3)), pinned=m.pinned), "no plasticity"),
    (lambda m: bar(loads=np.ones((len(m), 3))), "no nodal loads"),
    (lambda m: bar(velocities=np.ones((len(m), 3))), "node velocities cannot be set"),
])
def test_refusals_name_the_reason(change, reason):
    for static in (True, False):
        scene = Scene(parts=(change(bar()),), gravity=G, meta={"solve": "static"} if static else {})
        assert reason in ENGINE.supports(scene, "steady" if static else "symplectic_euler")


def test_refusals_of_stepper_and_unpinned_static_and_two_meshes():
    static, dynamic = static_scene(bar()), Scene(parts=(bar(),), gravity=G)
    assert ENGINE.supports(static, "steady") is None
    assert ENGINE.supports(dynamic, "symplectic_euler") is None
    assert "reached by 'steady'" in ENGINE.supports(static, "symplectic_euler")
    assert "offered as symplectic_euler" in ENGINE.supports(dynamic, "steady")
    assert "needs pinned nodes" in ENGINE.supports(static_scene(bar(pinned="none")), "steady")
    two = Scene(parts=(bar(), bar()), gravity=G)
    assert "one mesh per scene" in ENGINE.supports(two, "symplectic_euler")


def test_settings_state_the_law_masses_and_solver():
    sim = ENGINE.build(static_scene(bar()), 1.0, "steady")
    settings = sim.settings()
    sim.close()
    mu, lam = neo_hookean_coefficients(bar().material)
    lame_mu = 2e4 / (2 * 1.3)
    assert settings["NeoHookeanMu_Pa"] == mu == pytest.approx(4 / 3 * lame_mu, rel=1e-15)
    assert settings["NeoHookeanLambda_Pa"] == lam
    assert settings["mass_total_kg"] == pytest.approx(100.0 * 0.2 * 0.2 * 1.0, rel=1e-14)
    assert "setTotalMass" in settings["node_mass"] and settings["integrator"]["name"] == "steady"
    assert settings["w_min_rad_per_s"] > 0 and "stages" in settings["solver"]


@pytest.mark.slow
def test_long_bar_settles_within_its_stated_floor():
    """A 480-tetrahedron bar (2 x 2 x 20 cells) hanging from its top face: past h = 0.9 s the
    stages stop settling (even under-relaxed, b = 10 h: the damping solve's 300 iterations fall
    short) and restart with smaller steps; which restarts run varies from run to run (pybullet
    is not repeatable where that solve stalls), the outcome does not: the solve keeps the
    stage at h = 0.91 s, whose floor 1e-8 m/s / (h w_min^2) = 1e-9 m (observed as
    error_floor) bounds its distance from refsim's static solve with pybullet's masses
    (measured 1.1e-10..1.9e-10 m in 8 runs, 4-7 s each)."""
    nodes, tets = box_tetrahedra(2, 2, 20, 0.2, 0.2, 1.0)
    material = Material(2e4, 0.3, 100.0, "neo_hookean")
    pins = np.flatnonzero(nodes[:, 2] == 1.0)
    mesh = TetMesh(nodes, tets, material, pinned=pins)
    obs = solve(ENGINE, static_scene(mesh))
    loads = node_masses(mesh)[:, None] * np.array(G)
    same = solve(REFSIM, static_scene(TetMesh(nodes, tets, material, pinned=pins, loads=loads),
                                      gravity=(0.0, 0.0, 0.0)))
    assert np.abs(obs["x"] - same["x"]).max() <= obs["error_floor"]
