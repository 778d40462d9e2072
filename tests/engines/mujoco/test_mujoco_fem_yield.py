"""MuJoCo's flex plasticity (adapters/mujoco_engine/fem_yield.py, mujoco 4.0.0) measured on one
tetrahedron against refsim's von Mises rule: the yield surface, the return, when it runs, and
the plastic_set green variant's rows explained to round-off by MuJoCo's own rule.
mujoco is imported on purpose: CI must have every engine (fail, never skip).
"""
import json

import mujoco  # used directly; also: CI must have every engine (fail, never skip)
import numpy as np
import pytest

from refsim.engine import jsonable
from refsim.registry import get_case, get_engine
from refsim.run.job import Job, run_job
from refsim.scene import Material, Plasticity, Scene, TetMesh
from refsim_adapters.mujoco_engine.fem_yield import plastic_metrics, yield_strain
from refsim_cases.fem._plastic_green import GreenTet

MJ = get_engine("mujoco")
CASE = get_case("plastic_set")


class MujocoRule(GreenTet):
    """The green variant's three stretches under MuJoCo's rule (fem_yield's docstring): the same
    deviatoric radial return, then the volumetric part of E_p set by det(I + 2 E_p) = 1; with
    stage_return False the force takes the committed E_p without a return (MuJoCo's RK4)."""

    stage_return = True

    def _solve(self):  # only the discrete solutions are used here
        pass

    def ret(self, l, ep):
        e, new = super().ret(l, ep)
        if new is ep:
            return e, ep
        dev, s = new - np.sum(new) / 3.0, 0.0
        for _ in range(50):  # Newton on prod(1 + 2 (dev + s)) = 1
            f = 1.0 + 2.0 * (dev + s)
            s -= (np.prod(f) - 1.0) / (2.0 * np.sum(np.prod(f) / f))
        return 0.5 * (l * l - 1.0) - dev - s, dev + s

    def accel(self, l, ep):
        if self.stage_return:
            return super().accel(l, ep)
        e = 0.5 * (l * l - 1.0) - ep
        return -self.k * l * (self.lam * np.sum(e) + 2 * self.mu * e)


def _green():
    p = CASE.variant_params("green")
    return p, CASE.scene(p).parts[0]


def _dev(a):
    return a - np.trace(a) / 3.0 * np.eye(3)


def _stepped(mesh, f, dt=1e-14):
    """MuJoCo's plastic metric after one mj_step (dt 1e-14: the nodes stay put) from x = F X."""
    sim = MJ.build(Scene(parts=(mesh,), gravity=(0.0, 0.0, 0.0)), dt, "symplectic_euler")
    sim.data.qpos[:] = (mesh.vertices @ f.T - mesh.vertices).reshape(-1)
    sim.data.qvel[:] = 0.0
    mujoco.mj_forward(sim.model, sim.data)
    before = sim.data.plastic.copy()
    mujoco.mj_step(sim.model, sim.data)
    return before, plastic_metrics(sim.model, sim.data, mesh.vertices)[0]


def test_the_yield_surface_is_refsims_with_eps_y_sigma_y_over_3_mu():
    """MuJoCo yields where sqrt(2/3) |dev E| passes its `yield` eps_y; the adapter's eps_y =
    sigma_y / (3 mu) puts that at refsim's |2 mu dev E| = sqrt(2/3) sigma_y: a deviatoric
    Green strain 0.1 % inside stays elastic, 0.1 % outside flows (two directions)."""
    p, mesh = _green()
    mu = p["youngs_modulus"] / (2 * (1 + p["poisson_ratio"]))
    assert yield_strain(mesh) == p["yield_stress"] / (3 * mu)
    radius = np.sqrt(2.0 / 3.0) * p["yield_stress"] / (2 * mu)  # |dev E| at yield
    for n in (np.diag([2.0, -1.0, -1.0]) / np.sqrt(6.0),
              np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]) / np.sqrt(2.0)):
        for scale, flows in ((0.999, False), (1.001, True)):
            f = np.linalg.cholesky(np.eye(3) + 2 * scale * radius * n).T  # E = scale r n
            _, metric = _stepped(mesh, f)
            assert bool(np.any(metric != 0)) == flows


def test_the_return_is_radial_and_keeps_det_i_plus_p():
    """From a random F past yield: dev(E - P/2) is dev E scaled back to the yield radius (as
    refsim's return), and det(I + P) = 1 where refsim keeps tr E_p = 0 (measured to 1e-15;
    bound 1e-13, a 3 x 3 solve and return of O(1) numbers); the forward pass leaves P alone
    (the update is mj_step's)."""
    p, mesh = _green()
    f = np.eye(3) + np.random.default_rng(1).normal(size=(3, 3)) * 0.03
    before, metric = _stepped(mesh, f)
    green = 0.5 * (f.T @ f - np.eye(3))
    elastic = _dev(green - metric / 2)
    radius = np.sqrt(1.5) * yield_strain(mesh)
    assert not before.any()
    assert np.linalg.norm(elastic) == pytest.approx(radius, rel=1e-13)
    assert np.abs(elastic - radius * _dev(green) / np.linalg.norm(_dev(green))).max() <= 1e-13
    assert abs(np.linalg.det(np.eye(3) + metric) - 1.0) <= 1e-13
    assert np.trace(metric) > 1e-4  # the volumetric part refsim does not have


@pytest.mark.parametrize("integrator, gap", [("symplectic_euler", 6.547e-4), ("rk4", 1.203e-3)])
def test_the_green_run_is_mujocos_rule_step_for_step(integrator, gap):
    """MuJoCo's run of plastic_set green, every step, equals the three-stretch discrete solution
    under MuJoCo's rule (the update after each step; RK4's stages without a return) to
    round-off (measured 7e-16 m; bound 1e-13 m, 110 steps of O(1) positions), and the plastic
    metric at the end is 2 E_p of it; refsim's rule on the same steps is `gap` away at most
    (measured 6.547e-4 m Euler, 2.96e-4 m at the end; RK4 1.203e-3 m, the stages without a
    return on top): the volumetric plastic strain (rel 1e-3: the measured value's 4 digits)."""
    p, mesh = _green()
    c = CASE.constants(p)
    dt = CASE.reference_dt(p)
    steps = int(round(CASE.t_end(p) / dt))
    rule = MujocoRule(c, c["lam"])
    rule.stage_return = integrator != "rk4"
    stretches = rule.discrete(integrator, dt, steps)
    centre = mesh.vertices.mean(0)
    sim = MJ.build(Scene(parts=(mesh,), gravity=(0.0, 0.0, 0.0)), dt, integrator)
    xs = [sim.observe()["x"]]
    for _ in range(steps):
        sim.step(1)
        xs.append(sim.observe()["x"])
    x = centre + stretches[:, None, :] * (mesh.vertices - centre)
    assert np.abs(np.array(xs) - x).max() <= 1e-13
    state = {"ep": np.zeros(3)}
    for l in stretches[1:]:  # the committed E_p along the same path
        state["ep"] = rule.ret(l, state["ep"])[1]
    metric = plastic_metrics(sim.model, sim.data, mesh.vertices)[0]
    assert np.abs(metric - np.diag(2 * state["ep"])).max() <= 1e-13
    refsim_rule = CASE.discrete(p, integrator, dt, steps)
    apart = np.linalg.norm((stretches - refsim_rule)[:, None, :] * (mesh.vertices - centre),
                           axis=(1, 2))
    assert apart.max() == pytest.approx(gap, rel=1e-3)


def test_the_green_rows_are_honestly_inconsistent():
    """plastic_set green on MuJoCo: Euler's row passes the in-house bound by ~50x (6.5e-4 m
    against 1.2e-5 m: the volumetric plastic strain, tr E_p = 1.0e-3), and its settings state
    the yield mapping and what differs."""
    p, mesh = _green()
    row = run_job(Job("plastic_set", "green", "mujoco", "", "symplectic_euler",
                      CASE.reference_dt(p)), repeats=0)
    assert row["status"] == "ok" and row["consistency"] == "inconsistent"
    assert row["err_max"] > 10 * row["tolerance"]
    s = json.loads(row["settings"])["plasticity"]
    assert s["yield_strain"] == yield_strain(mesh) and "det(I + 2 E_p) = 1" in s["differs"]
    sim = MJ.build(CASE.scene(p), CASE.reference_dt(p), "rk4")
    assert json.loads(json.dumps(jsonable(sim.settings())))["plasticity"]["yield_stress"] == 10


def test_plasticity_refusals():
    """Hardening (MuJoCo's yield is ideal), sigma_y = 0 (MuJoCo's elastic flex) and a static
    plastic scene (the path decides the plastic strain) are refused; triangles too (their
    refusal is in test_mujoco_fem.py)."""
    _, mesh = _green()

    def scene(plasticity, meta=None):
        m = mesh.material
        tet = TetMesh(mesh.vertices, mesh.tetrahedra,
                      Material(m.youngs_modulus, m.poisson_ratio, m.density, "green",
                               plasticity), velocities=mesh.velocities)
        return Scene(parts=(tet,), gravity=(0.0, 0.0, 0.0), meta=meta or {})

    assert "no hardening" in MJ.supports(scene(Plasticity(10.0, 200.0)))
    assert "elastic flex" in MJ.supports(scene(Plasticity(0.0)))
    assert "path" in MJ.supports(scene(Plasticity(10.0), {"solve": "static"}), "steady")
    assert MJ.supports(scene(Plasticity(10.0)), "rk4") is None


def test_plastic_metrics_reads_every_element_in_its_edge_order():
    """A 12-tetrahedron box under one affine F past yield: every element's metric, read
    through flex_elemedge, is the same P (measured 1.4e-15 apart; bound 1e-13, as above)
    with det(I + P) = 1; a wrong edge order would mix elements of different orientation."""
    from refsim.models.fem.meshes import box_tetrahedra
    _, tet = _green()
    nodes, cells = box_tetrahedra(2, 1, 1)
    mesh = TetMesh(nodes, cells, tet.material)
    f = np.eye(3) + np.random.default_rng(2).normal(size=(3, 3)) * 0.03
    _, first = _stepped(mesh, f)
    sim = MJ.build(Scene(parts=(mesh,), gravity=(0.0, 0.0, 0.0)), 1e-14, "symplectic_euler")
    sim.data.qpos[:] = (nodes @ f.T - nodes).reshape(-1)
    mujoco.mj_step(sim.model, sim.data)
    metrics = plastic_metrics(sim.model, sim.data, nodes)
    assert len(metrics) == 12 and np.abs(metrics - first).max() <= 1e-13
    assert abs(np.linalg.det(np.eye(3) + first) - 1.0) <= 1e-13 and np.abs(first).max() > 0.01
