"""taichi's bending kernels (hinges, dihedrals) against refsim's model for the three explicit
steppers: a hair under gravity (hinges, rest angle 0, clamped root), a curly hair (nonzero rest
angles, the theta0 branch), and the tilted cloth of cloth_hang's `bending` variant (dihedrals);
the hair_cantilever default rows on taichi within the case's tolerance; Baraff-Witkin's refusal;
a network without bending keeps the stretch-only kernels.

Round-off bound (the argument of test_taichi_spring_network.py, widened for bending). One force
evaluation is, per node, at most 64 roundings for its stretch springs and drag and 128 for each
bending tuple it belongs to (a hinge: 2 edge differences, 2 norms, 2 unit vectors, a dot, a
cross and its norm, atan2 and sin (libm, within 1 ulp each: counted as roundings), the 1/sinc
and theta0 terms, the two 3-vectors g1, g2 of 4 operations a component, the per-node sum;
a dihedral: 2 crosses, the edge norm, 2 dots, atan2, the 4 gradient vectors, the torque
product: under 128 too). RK4 evaluates four times a step, so K = 4 (64 + 128 T) roundings per
node per step, T the most tuples a node belongs to. With h omega_max <= 0.6 the step is
non-expansive and k steps add: |dx| <= k K eps S_x, |dv| <= k K eps (S_v + omega_max S_x),
omega_max^2 the largest |eigenvalue| of refsim's da/dx (exact Jacobians, hinge and dihedral
Hessians included) at the start and at the end of the run. (Measured: the planar hair runs are
bit-identical; the curly hair and the cloth differ by a few ulp of x (<= 4e-15 m after 150
steps, against bounds of 6e-11 m and up), a rounding difference of some operation not traced.)
"""
import numpy as np
import pytest

from refsim_cases.spring_network import cloth_hang, hair_cantilever
from refsim import registry
from refsim.run.job import Job, run_job
from refsim.models.spring_network import NetworkSystem
from refsim.scene import Scene, SpringNetwork

pytest.importorskip("taichi")
EPS = np.finfo(float).eps
TAICHI, REFSIM = registry.get_engine("taichi"), registry.get_engine("refsim")
EXPLICIT = ("symplectic_euler", "velocity_verlet", "rk4")
STEPS = 150


def hair_scene():
    """hair_cantilever's default scene: 6 free links, hinges at rest angle 0, heavy tip."""
    return hair_cantilever.CASE.scene(hair_cantilever.CASE.variant_params("default"))


def curly_scene(links=8, turn=0.2, rest=0.3):
    """A chain clamped at nodes 0, 1, bent by `turn` at every node in the x-z plane and tilted
    out of it (y), rest angle `rest` != 0 at every hinge: it curls up, under gravity and drag."""
    phi = np.r_[0.0, turn * np.arange(1, links + 1)]
    steps = 0.1 * np.c_[np.cos(phi), 0.3 * np.sin(phi), np.sin(phi)]
    x = np.r_[np.zeros((1, 3)), np.cumsum(steps, axis=0)]
    chain = np.arange(links + 2)
    net = SpringNetwork(positions=x, masses=0.02, edges=np.c_[chain[:-1], chain[1:]],
                        stiffness=400.0, damping=0.05, hinges=np.c_[chain[:-2], chain[1:-1],
                                                                    chain[2:]],
                        hinge_stiffness=0.05, hinge_rest_angle=rest, pinned=[0, 1])
    return Scene(parts=(net,), gravity=(0, 0, -9.81), linear_drag=0.01)


def cloth_scene():
    """cloth_hang's `bending` variant: a 6 x 6 cloth tilted 0.5 rad, dihedrals, corners pinned."""
    return cloth_hang.CASE.scene(cloth_hang.CASE.variant_params("bending"))


SCENES = {"hair": hair_scene, "curly": curly_scene, "cloth": cloth_scene}


def omega_max(scene, states):
    """sqrt of the largest |eigenvalue| of refsim's da/dx over `states` (full x, v)."""
    system = NetworkSystem(scene.part(SpringNetwork), scene.gravity, scene.linear_drag)
    out = 0.0
    for x, v in states:
        ax, _ = system.jacobians(0.0, x[system.free].ravel(), v[system.free].ravel())
        out = max(out, float(np.sqrt(np.max(np.abs(np.linalg.eigvals(ax))))))
    return out


def roundings(net):
    """K = 4 (64 + 128 T): T the most bending tuples any node belongs to (module doc)."""
    tuples = np.r_[np.reshape(net.hinges, -1), np.reshape(net.dihedrals, -1)].astype(int)
    return 4 * (64 + 128 * int(np.max(np.bincount(tuples))))


def stable_step(scene):
    """dt = 0.5 / omega_max at the start (h omega <= 0.6 checked at the end too)."""
    net = scene.part(SpringNetwork)
    return 0.5 / omega_max(scene, [(net.positions, net.velocities)])


def run(engine, scene, dt, integrator):
    sim = engine.build(scene, dt, integrator, "")
    for n in (1, STEPS // 2 - 1, STEPS - STEPS // 2):  # split calls: state carried over
        sim.step(n)
    assert sim.failure is None, sim.failure
    obs = sim.observe()
    sim.close()
    return obs


@pytest.mark.parametrize("integrator", EXPLICIT)
@pytest.mark.parametrize("name", sorted(SCENES))
def test_explicit_steppers_match_refsim(name, integrator):
    scene = SCENES[name]()
    net, dt = scene.part(SpringNetwork), stable_step(scene)
    ours, theirs = run(TAICHI, scene, dt, integrator), run(REFSIM, scene, dt, integrator)
    omega = omega_max(scene, [(net.positions, net.velocities), (theirs["x"], theirs["v"])])
    assert omega * dt <= 0.6
    k = STEPS * roundings(net) * EPS
    s_x, s_v = np.max(np.abs(theirs["x"])), np.max(np.abs(theirs["v"]))
    assert np.max(np.abs(ours["x"] - theirs["x"])) <= k * s_x
    assert np.max(np.abs(ours["v"] - theirs["v"])) <= k * (s_v + omega * s_x)
    # the bending forces matter: the same run without them ends far outside that bound
    assert np.max(np.abs(theirs["x"] - unbent_run(scene, dt, integrator))) > 1e3 * k * s_x


def unbent_run(scene, dt, integrator):
    net = scene.part(SpringNetwork)
    plain = SpringNetwork(positions=net.positions, masses=net.masses, edges=net.edges,
                          stiffness=net.stiffness, rest_length=net.rest_length,
                          damping=net.damping, pinned=net.pinned)
    return run(REFSIM, Scene(parts=(plain,), gravity=scene.gravity,
                          linear_drag=scene.linear_drag), dt, integrator)["x"]


@pytest.mark.parametrize("case, variant", [(hair_cantilever, "default"),
                                           (cloth_hang, "bending")])
@pytest.mark.parametrize("integrator", EXPLICIT)
def test_case_rows_within_tolerance(case, variant, integrator):
    """The hair (hinges) against its exact equilibrium, the dihedral cloth against
    cloth_hang's converged reference: taichi's rows within each case's own tolerance
    (run_job looks the case up by its installed entry point)."""
    name = case.CASE.name
    assert name in registry.case_names()
    p = case.CASE.variant_params(variant)
    row = run_job(Job(name, variant, "taichi", "", integrator, case.CASE.reference_dt(p)),
                  repeats=0)
    column = case.CASE.tolerance_column(p)
    assert row["status"] == "ok", row["reason"]
    assert (row["consistency"] == "consistent"), f"{row[column]:.3g} > {row['tolerance']:.3g}"


def test_baraff_witkin_refuses_bending_and_settings_name_the_terms():
    for scene in (hair_scene(), cloth_scene()):
        reason = TAICHI.supports(scene, "baraff_witkin")
        assert reason is not None and "Hessian" in reason
    sim = TAICHI.build(hair_scene(), 1e-3, "rk4", "")
    model = sim.settings()["model"]
    assert model["terms"] == ["stretch", "hinge"] and model["hinges"] == 6
    assert "bending" in sim.settings()
    sim = TAICHI.build(cloth_scene(), 1e-3, "symplectic_euler", "")
    assert sim.settings()["model"]["terms"] == ["stretch", "dihedral"]


def test_network_without_bending_keeps_the_stretch_only_kernels():
    from refsim_adapters.taichi_engine import network_kernels as nk
    p = hair_cantilever.CASE.variant_params("default")
    net = hair_cantilever.CASE.network(p)
    plain = SpringNetwork(positions=net.positions, masses=net.masses, edges=net.edges,
                          stiffness=net.stiffness, rest_length=net.rest_length, pinned=net.pinned)
    sim = TAICHI.build(Scene(parts=(plain,), gravity=(0, 0, -9.81)), 1e-3, "rk4", "")
    assert sim.stepper_kernels == (nk.start, nk.symplectic_euler, nk.velocity_verlet, nk.rk4)
    assert sim.settings()["model"]["terms"] == ["stretch"] and "bending" not in sim.settings()
