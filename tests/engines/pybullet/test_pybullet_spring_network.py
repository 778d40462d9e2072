"""pybullet's spring-network group ("softbody": its own mass-spring soft body): agreement with
refsim's symplectic Euler on the same network, the first-order gap its implicit damping leaves,
the mesh it is given, and the networks it refuses with their reasons.

Round-off bounds: x is pybullet's own float64 state; v is observed as (x_n - x_{n-1}) / h, so
its round-off is about |x| eps / h = 0.5 m * 2.2e-16 / 1e-3 s ~ 1e-13 m/s per step difference,
grown over a few hundred steps: 1e-11 m/s and 1e-13 m are bounds with margin for that.
"""
import numpy as np
import pybullet  # noqa: F401  (fail, never skip, without the engine)
import pytest

from refsim_adapters.pybullet_engine.softbody import triangles
from refsim.registry import get_engine
from refsim.scene import Scene, SpringNetwork

ENGINE = get_engine("pybullet")
REFSIM = get_engine("refsim")
SE = "symplectic_euler"
X_ROUNDOFF, V_ROUNDOFF = 1e-13, 1e-11  # m, m/s: see the module doc


def cloth(n=5, spacing=0.1, damping=0.0, shear=True):
    """n x n cloth in the x-z plane, structural (+ both shear diagonals), hanging from its two
    top corners."""
    ix, iz = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    idx = ix * n + iz
    pos = np.stack([ix.ravel() * spacing, np.zeros(n * n), -iz.ravel() * spacing], axis=1)
    pairs = [(idx[:-1, :], idx[1:, :]), (idx[:, :-1], idx[:, 1:])]
    if shear:
        pairs += [(idx[:-1, :-1], idx[1:, 1:]), (idx[1:, :-1], idx[:-1, 1:])]
    edges = np.concatenate([np.stack([a.ravel(), b.ravel()], 1) for a, b in pairs])
    net = SpringNetwork(positions=pos, masses=0.01, edges=edges, stiffness=40.0,
                        damping=damping, pinned=[0, n * (n - 1)])
    return Scene(parts=(net,), gravity=(0.0, 0.0, -9.81))


def membrane(n=4, tension_k=20.0, amplitude=0.01):
    """n x n free nodes in the x-y plane inside a pinned ring, triangulated (one diagonal per
    square), zero rest length, the lowest mode's z displacement, no gravity."""
    m = n + 2
    ix, iy = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
    idx = ix * m + iy
    pos = np.stack([ix.ravel() / (m - 1), iy.ravel() / (m - 1), np.zeros(m * m)], axis=1)
    pos[:, 2] = amplitude * np.sin(np.pi * pos[:, 0]) * np.sin(np.pi * pos[:, 1])
    edges = np.concatenate([np.stack([a.ravel(), b.ravel()], 1) for a, b in (
        (idx[:-1, :], idx[1:, :]), (idx[:, :-1], idx[:, 1:]), (idx[:-1, :-1], idx[1:, 1:]))])
    ring = (ix == 0) | (iy == 0) | (ix == m - 1) | (iy == m - 1)
    net = SpringNetwork(positions=pos, masses=0.02, edges=edges, stiffness=tension_k,
                        rest_length=0.0, pinned=idx[ring])
    return Scene(parts=(net,), gravity=(0.0, 0.0, 0.0))


def run_both(scene, dt, steps):
    out = []
    for engine, variant in ((ENGINE, "softbody"), (REFSIM, "")):
        sim = engine.build(scene, dt, SE, variant)
        sim.step(steps)
        out.append(sim.observe())
        if hasattr(sim, "close"):
            sim.close()
    return out


@pytest.mark.parametrize("scene", [cloth(), membrane()], ids=["cloth", "membrane_zero_rest"])
def test_undamped_matches_symplectic_euler_to_roundoff(scene):
    """Without damping pybullet's deformable step is kick (gravity + elastic at x_n) then drift:
    refsim's symplectic Euler on the same forces."""
    pb, ref = run_both(scene, 1e-3, 300)
    moved = np.abs(ref["x"] - scene.part(SpringNetwork).positions).max()
    assert moved > 1e-3  # the network really moves (about 3 cm and 1 cm)
    np.testing.assert_allclose(pb["x"], ref["x"], rtol=0, atol=X_ROUNDOFF)
    np.testing.assert_allclose(pb["v"], ref["v"], rtol=0, atol=V_ROUNDOFF)


def test_implicit_damping_gap_is_first_order():
    """pybullet solves edge damping implicitly, refsim's symplectic Euler explicitly: the two
    first-order steps differ by O(h) at a fixed time, so halving h halves the gap (ratio 2 up to
    O(h) corrections: 1.8..2.2 for h c / m = 2e-3..1e-3 here)."""
    scene = cloth(damping=0.02)
    gaps = []
    for dt in (1e-3, 5e-4):
        pb, ref = run_both(scene, dt, int(round(0.3 / dt)))
        gaps.append(np.abs(pb["x"] - ref["x"]).max())
    assert gaps[0] > 100 * X_ROUNDOFF  # a real gap, not round-off
    assert 1.8 < gaps[0] / gaps[1] < 2.2


def test_mesh_holds_exactly_the_network_edges():
    scene = cloth(n=4)
    net = scene.part(SpringNetwork)
    tris = triangles(len(net), net.edges)
    sides = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [0, 2]]])
    sides = np.unique(np.sort(sides[sides[:, 0] != sides[:, 1]], axis=1), axis=0)
    np.testing.assert_array_equal(sides, np.unique(np.sort(net.edges, axis=1), axis=0))


def test_edges_in_no_triangle_refused():
    """A rope or a structural-only grid has edges in no triangle: pybullet builds links only
    from mesh triangles, and a degenerate triangle (i, j, j) crashed pybullet 3.2.7."""
    reason = ENGINE.supports(cloth(shear=False), SE)
    assert reason is not None and "no triangle" in reason


def _refusal(**changes):
    base = cloth(n=3)
    net = base.part(SpringNetwork)
    fields = dict(positions=net.positions, masses=net.masses, edges=net.edges,
                  stiffness=net.stiffness, damping=net.damping, pinned=net.pinned)
    drag = changes.pop("linear_drag", 0.0)
    fields.update(changes)
    scene = Scene(parts=(SpringNetwork(**fields),), gravity=base.gravity, linear_drag=drag)
    return ENGINE.supports(scene, SE)


@pytest.mark.parametrize("changes, words", [
    (dict(linear_drag=0.1), "drag"),
    (dict(stiffness=np.linspace(10, 20, 20)), "stiffness"),
    (dict(masses=np.linspace(0.01, 0.02, 9)), "masses"),
    (dict(velocities=np.r_[[[0.0, 0.0, 0.0]], np.ones((5, 3)), [[0.0, 0.0, 0.0]],
                           np.ones((2, 3))]), "velocities"),  # pinned nodes 0 and 6 at rest
    (dict(rest_length=np.linspace(0.05, 0.1, 20)), "rest lengths"),
    (dict(hinges=[[0, 1, 2]], hinge_stiffness=1.0), "angle springs"),
])
def test_refuses_what_it_cannot_express(changes, words):
    reason = _refusal(**changes)
    assert reason is not None and words in reason


def test_other_steppers_refused_and_settings_reported():
    scene = cloth(n=3)
    for stepper in ("velocity_verlet", "rk4", "baraff_witkin"):  # offered: symplectic_euler
        reason = ENGINE.supports(scene, stepper)
        assert reason is not None and stepper in reason
    assert ENGINE.formulations(scene) == ("softbody",)
    sim = ENGINE.build(scene, 1e-3, SE, "softbody")
    settings = sim.settings()
    sim.close()
    assert settings["fixedTimeStep"] == 1e-3 and settings["numSubSteps"] == 0
    assert settings["springElasticStiffness_N_per_m"] == 40.0
    assert settings["velocity_clamp_component_m_per_s"] == pytest.approx(1e6)
    assert settings["integrator"]["damping_implicit"] is False
