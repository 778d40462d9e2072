"""taichi's implicit FEM steppers (adapters' fem_implicit: implicit_euler, baraff_witkin with
taichi's SparseSolver LDLT) against refsim's (refsim.integrators.implicit on FemSystem):
short trajectories at steps far past the explicit steppers' stability limit, the verdicts of
every case refsim runs with these steppers, and the settings.

Bound of a trajectory (test_taichi_fem.py's, with the solve's terms). Both sides solve the
same linear system per step (taichi M + h^2 K, refsim the same divided by M, dense LU or
SuperLU); a backward-stable solve errs by K eps cond |dv|, cond <= (1 + y^2) m_max / m_min
in the max norm (y = omega h), and the forces round within K eps S_a as there. So a step adds
at most delta = K eps ((S_x + h S_v) + (S_v + h A) (1 + y^2) c_m / omega) in the norm
|dx| + |dv| / omega (c_m = m_max / m_min); implicit Euler's Newton stops where the update is
below tol (1 + |v1|), so the two may stop one iteration apart: at most tol (1 + S_v) more on
v per step (the simplified Newton contracts by h^2 |dK| / (1 + y^2) < 1/2 an iteration here).
Backward Euler and its linearisation are non-expansive in the energy norm (amplification
1 / sqrt(1 + y^2) per mode on the linear part), within sqrt(c_m) of the max norm: after k
steps |dx| <= G k delta, |dv| <= G k delta omega, G = 2 sqrt(c_m) (the nonlinear laws'
tangent changes along these runs by under a factor 2 in omega).
"""
import json

import numpy as np
import pytest

from refsim import registry
from refsim.engine import jsonable
from refsim.models.fem.meshes import box_tetrahedra, perturb_interior, rectangle_triangles
from refsim.models.fem.model import ElasticBody
from refsim.models.fem.system import FemSystem
from refsim.run.job import Job, run_job
from refsim.scene import Material, Scene, TetMesh, TriangleMesh

pytest.importorskip("taichi")
EPS = np.finfo(float).eps
K = 64  # roundings along one nodal force (test_taichi_fem.py)
TOL = 1e-13  # refsim's ImplicitEuler tol (read back from the settings below)
TAICHI, REFSIM = registry.get_engine("taichi"), registry.get_engine("refsim")
STEPS = 40


def mesh_of(kind, law, seed=4, tilt=False):
    """A tiny irregular mesh, the x = 0 face pinned, free nodes displaced at random by up to
    5 % in the initial positions, random loads on them; `tilt`: a triangle mesh in the
    vertical plane through z and (cos 30, sin 30, 0) (plane coordinates cost roundings)."""
    rng = np.random.default_rng(seed)
    material = Material(1000.0, 0.3, 100.0, law)
    if kind == "tet":
        nodes, cells = box_tetrahedra(2, 1, 1, 1.0, 0.5, 0.5)
        nodes[[4, 7, 10], 0] += 0.06 * np.array([1.0, -1.0, 0.5])
    else:
        nodes, cells = rectangle_triangles(3, 2, 1.0, 0.6)
        nodes = perturb_interior(nodes, 0.05, seed=seed + 1)
    pinned = np.flatnonzero(nodes[:, 0] == 0.0)
    free = np.setdiff1d(np.arange(len(nodes)), pinned)
    axes = 3 if kind == "tet" else 2
    positions, load = nodes.copy(), np.zeros_like(nodes)
    positions[free, :axes] += 0.05 * rng.uniform(-1.0, 1.0, (len(free), axes))
    load[free, :axes] = rng.uniform(-2.0, 2.0, (len(free), axes))
    if kind == "tet":
        return TetMesh(nodes, cells, material, pinned=pinned, loads=load, positions=positions)
    if tilt:
        c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
        turn = np.array([[c, 0.0, 0.0], [s, 0.0, 0.0], [0.0, 1.0, 0.0]])
        nodes, positions, load = nodes @ turn.T, positions @ turn.T, load @ turn.T
    return TriangleMesh(nodes, cells, material, thickness=0.1, plane=kind, pinned=pinned,
                        loads=load, positions=positions)


def omega_max(system, xs):
    """max over world states x (n, 3) of sqrt(max |eig(M^-1 K)|), refsim's tangent."""
    out = 0.0
    for x in xs:
        jx, _ = system.jacobians(0.0, x[system.free].ravel(), np.zeros(3 * system.nbody))
        out = max(out, float(np.sqrt(np.max(np.abs(np.linalg.eigvals(jx))))))
    return out


def force_scale(body, x):
    """S_a (n,) of test_taichi_fem.py: node a's elements' V |grad phi_a|_1 sigma_e."""
    law = getattr(body.law, "law", body.law)
    f = body.deformation_gradient(x)
    sigma = 16 * (2 * law.mu + 3 * abs(law.lam)) * np.maximum(1.0, np.abs(f).max(
        axis=(1, 2))) ** 5
    el = body.elements
    return el.gather(el.volume[:, None] * np.abs(el.grad).sum(-1) * sigma[:, None])


# (mesh kind, law, y = omega h at the start: 2 to 8, at or past every explicit stepper's
# limit; the simplified Newton fails past y = 2-5 on these meshes, in refsim as here)
IMPLICIT = [("implicit_euler", "tet", "green", 2.0),
            ("implicit_euler", "strain", "neo_hookean", 5.0),  # in the tilted plane
            ("baraff_witkin", "stress", "green", 8.0),
            ("baraff_witkin", "tet", "linear", 3.0)]


@pytest.mark.slow  # 1-3 s each: the JIT of the forces and tangent kernels
@pytest.mark.parametrize("integrator,kind,law,y", IMPLICIT)
def test_implicit_trajectories_match_refsim(integrator, kind, law, y):
    """Released from a random 5 % deformation under gravity and loads: x, v after STEPS
    steps (calls of 1, 19 and 20 steps) within the module docstring's bound."""
    tilt = kind == "strain"
    mesh = mesh_of(kind, law, tilt=tilt)
    gravity = (0.0, 0.0, -9.81) if kind == "tet" or tilt else (0.0, -9.81, 0.0)
    scene = Scene(parts=(mesh,), gravity=gravity)
    system = FemSystem(mesh, gravity)
    dt = y / omega_max(system, [np.array(mesh.positions)])
    samples, out = [], []
    for engine in (TAICHI, REFSIM):
        sim = engine.build(scene, dt, integrator)
        for n in (1, 19, 20):
            sim.step(n)
            samples.append(sim.observe())
        assert sim.failure is None, sim.failure
        out.append(sim.observe())
        sim.close()
    ours, theirs = out
    omega = omega_max(system, [mesh.positions] + [s["x"] for s in samples])
    body = ElasticBody.of(mesh)
    c_m = system.masses.max() / system.masses.min()
    accel = max(np.max(force_scale(body, body.to_local(s["x"]))[system.free] / system.masses)
                for s in samples)
    s_x = max(np.max(np.abs(s["x"])) for s in samples)
    s_v = max(np.max(np.abs(s["v"])) for s in samples)
    yy = (omega * dt) ** 2
    delta = K * EPS * ((s_x + dt * s_v) + (s_v + dt * accel) * (1 + yy) * c_m / omega)
    if integrator == "implicit_euler":
        delta += TOL * (1 + s_v) / omega
    bound = 2 * np.sqrt(c_m) * STEPS * delta
    assert np.max(np.abs(ours["x"] - theirs["x"])) <= bound
    assert np.max(np.abs(ours["v"] - theirs["v"])) <= bound * omega
    assert np.max(np.abs(theirs["x"] - mesh.positions)) > 1e6 * bound  # it moved far more
    assert np.array_equal(ours["x"][mesh.pinned], mesh.positions[mesh.pinned])
    assert not ours["v"][mesh.pinned].any()


@pytest.mark.slow  # 1-3 s: the JIT (shared with the test above where it ran first)
def test_newton_failure_is_refsims():
    """At y = 8 on the tilted Neo-Hookean mesh the simplified Newton (matrix at the
    predictor) does not converge in 50 iterations on the first step, in refsim and in taichi
    alike: the same failure, at the same time."""
    mesh = mesh_of("strain", "neo_hookean", tilt=True)
    scene = Scene(parts=(mesh,), gravity=(0.0, 0.0, -9.81))
    dt = 8.0 / omega_max(FemSystem(mesh, scene.gravity), [np.array(mesh.positions)])
    failures = []
    for engine in (TAICHI, REFSIM):
        sim = engine.build(scene, dt, "implicit_euler")
        sim.step(3)
        failures.append(sim.failure)
    assert failures[0] == failures[1] == ("implicit_euler: Newton did not converge in 50 "
                                          "iterations at t=0")


# every dynamic case variant refsim runs with the implicit steppers (their default variants,
# and rigid_rotation's other laws)
CASES = [("rigid_rotation", v) for v in ("linear", "green", "corotated", "neo_hookean")] + [
    ("bending_frequency", "n2"), ("plastic_set", "default")]


@pytest.mark.slow  # 0.5-5 s each (JIT, and refsim's own run of 170-300 steps)
@pytest.mark.parametrize("integrator", ["implicit_euler", "baraff_witkin"])
@pytest.mark.parametrize("case_name,variant", CASES)
def test_case_verdicts_are_refsims(case_name, variant, integrator):
    """At the case's reference dt: the same status, consistency verdict and target verdict as
    refsim's row (plastic_set's other variants: test_taichi_fem_plastic.py)."""
    case = registry.get_case(case_name)
    dt = case.reference_dt(case.variant_params(variant))
    rows = [run_job(Job(case_name, variant, engine, "", integrator, dt), repeats=0)
            for engine in ("taichi", "refsim")]
    ours, theirs = ({k: r[k] for k in ("status", "consistency", "reaches_target")}
                    for r in rows)
    assert ours == theirs and ours["status"] == "ok", rows[0]["reason"]


def test_settings_state_the_solver_and_newton_rule():
    mesh = mesh_of("stress", "green")
    sim = TAICHI.build(Scene(parts=(mesh,)), 1e-3, "implicit_euler")
    sim.step(2)
    out = sim.settings()
    assert out["integrator"]["name"] == "implicit_euler" and "LDLT" in out["solver"]
    assert out["newton_tol"] == TOL and out["newton_max_iter"] == 50
    assert "once per step" in out["integrator"]["native"]
    assert out["dtype"] == "float64" and out["model"]["damping"] == "none"
    assert sim.compile_s > 0
    json.dumps(jsonable(out))
    sim = TAICHI.build(Scene(parts=(mesh,)), 1e-3, "baraff_witkin")
    out = sim.settings()
    assert out["integrator"]["name"] == "baraff_witkin" and "newton_tol" not in out
    assert "K v" in out["integrator"]["native"]
