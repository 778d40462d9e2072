"""taichi's von Mises plasticity (adapters' fem_plastic, committed by every stepper) against
refsim's (refsim.models.fem.plasticity, FemSystem.advance): the radial return on random
deformation gradients from random committed states (ideal and hardening; linear, green and
corotated; tetrahedra and plane strain), and plastic_set's variants run to their end on
both engines with all six steppers.

Round-off bounds. The return is a few dozen roundings (the strain: F^T F or the SVD's
V diag(s) V^T, about 10 a term; dev, |dev|, dgamma, n, sigma: about 20), each of relative
size eps on a term of size at most the trial stress scale 2 mu + 3 |lam| times |eps| <=
max(1, |F|)^2, and P = factor sigma multiplies by |F| (3 terms a sum): |P_ti - P_refsim| <=
K eps (2 mu + 3 |lam|) max(1, |F|)^3 (1 + |eps_p|) with K = 64 as in test_taichi_fem.py
(svd3 and LAPACK's SVD agree within K eps max|F| / min |s_j + s_k| there, the rotation's
condition, here <= 1 on F = I + 0.1 N(0, 1)); the committed eps_p and a within K eps
(1 + |eps_p| + max(1, |F|)^2). Trajectories: the radial return is the closest-point
projection onto the (convex) elastic domain in the energy norm, non-expansive, so the
trajectory bound of test_taichi_fem.py holds unchanged (G k delta, with the state, force
and acceleration sizes of the run).
"""
import numpy as np
import pytest

from refsim import registry
from refsim.models.fem.model import ElasticBody
from refsim.models.fem.system import FemSystem
from refsim.scene import Material, Plasticity, TetMesh, TriangleMesh
from refsim.models.fem.meshes import box_tetrahedra, rectangle_triangles

pytest.importorskip("taichi")
EPS = np.finfo(float).eps
K = 64  # roundings along a term (module docstring; test_taichi_fem.py's)
TAICHI, REFSIM = registry.get_engine("taichi"), registry.get_engine("refsim")
CASE = registry.get_case("plastic_set")
STEPPERS = ("explicit_euler", "symplectic_euler", "velocity_verlet", "rk4", "implicit_euler",
            "baraff_witkin")


def group():
    from refsim_adapters.taichi_engine.groups import fem
    return fem


def plastic_mesh(law, kind, hardening):
    material = Material(1000.0, 0.3, 100.0, law, Plasticity(5.0, hardening))
    if kind == "tet":
        nodes, cells = box_tetrahedra(3, 2, 2, 1.0, 1.0, 1.0)
        return TetMesh(nodes, cells, material)
    nodes, cells = rectangle_triangles(6, 5, 1.0, 1.0)
    return TriangleMesh(nodes, cells, material, thickness=0.1, plane="strain")


def return_kernel(data):
    from refsim_adapters.taichi_engine.fem_plastic import plastic_functions
    from refsim_adapters.taichi_engine.kernel_types import f64, ti
    stress, commit = plastic_functions(data.law["name"], data.plane_strain)
    mat = ti.types.ndarray(dtype=ti.types.matrix(data.d, data.d, f64), ndim=1)

    @ti.kernel
    def evaluate(P: data.k.pack_t, f: mat, out: mat):
        for e in range(f.shape[0]):
            out[e] = stress(P, f[e], e)
            commit(P, f[e], e)

    return evaluate


@pytest.mark.slow  # ~1.5-3 s: a kernel family per law and kind (the JIT)
@pytest.mark.parametrize("hardening", [0.0, 200.0])
@pytest.mark.parametrize("law,kind", [("linear", "tet"), ("green", "tet"),
                                      ("corotated", "tet"), ("corotated", "strain"),
                                      ("linear", "strain")])
def test_radial_return_is_refsims(law, kind, hardening):
    """Stress after the return and the committed state, from random committed plastic
    strains (traceless, symmetric, up to 0.02) and equivalent strains, at F = I + 0.1 N(0, 1):
    most elements yield (sigma_y = 5 Pa against strains of 0.1 at 2 mu = 770 Pa)."""
    mesh = plastic_mesh(law, kind, hardening)
    data = group().FemData(mesh, (0.0, 0.0, 0.0))
    law_ref = ElasticBody.of(mesh).law
    m, d = len(data.body.elements.cells), data.d
    rng = np.random.default_rng(11)
    eps_p = 0.01 * rng.normal(size=(m, 3, 3))
    eps_p = 0.5 * (eps_p + np.swapaxes(eps_p, 1, 2))
    eps_p -= np.trace(eps_p, axis1=1, axis2=2)[:, None, None] / 3.0 * np.eye(3)
    if kind == "strain":
        eps_p[:, 2, :2] = eps_p[:, :2, 2] = 0.0
    equiv = 0.02 * rng.uniform(size=m)
    data.arrays["eps_p"].from_numpy(eps_p)
    data.arrays["equiv"].from_numpy(equiv)
    law_ref.plastic_strain, law_ref.equivalent = eps_p.copy(), equiv.copy()
    f = np.eye(d) + 0.1 * rng.normal(size=(m, d, d))
    ours = np.zeros_like(f)
    return_kernel(data)(data.pack, f, ours)
    theirs = law_ref.stress(f)
    law_ref.commit(f)
    mu, lam = law_ref.mu, law_ref.lam
    size = np.maximum(1.0, np.abs(f).max(axis=(1, 2)))
    bound = K * EPS * (2 * mu + 3 * abs(lam)) * size ** 3 * (1 + np.abs(eps_p).max())
    assert np.all(np.abs(ours - theirs).max(axis=(1, 2)) <= bound)
    state_bound = K * EPS * (1 + np.abs(eps_p).max() + size.max() ** 2)
    got_p, got_a = data.plastic_state()
    assert np.abs(got_p - law_ref.plastic_strain).max() <= state_bound
    assert np.abs(got_a - law_ref.equivalent).max() <= state_bound
    flowed = law_ref.equivalent - equiv
    assert np.mean(flowed > 0) > 0.5 and flowed.max() > 1e6 * state_bound  # most yield


def run_to_end(engine, scene, dt, steps, integrator):
    sim = engine.build(scene, dt, integrator)
    sim.step(steps // 2)
    sim.step(steps - steps // 2)
    assert sim.failure is None, sim.failure
    return sim


# every variant, each by an explicit and an implicit stepper (all six on the default): the
# steppers' commit points differ (inside each kernel's time loop, after the implicit step)
PLASTIC_SET = [("default", name) for name in STEPPERS] + [
    ("hardening", "velocity_verlet"), ("hardening", "implicit_euler"),
    ("plane_strain", "rk4"), ("plane_strain", "baraff_witkin"),
    ("green", "explicit_euler"), ("green", "implicit_euler"),
    ("sweep", "symplectic_euler"), ("sweep", "baraff_witkin")]


@pytest.mark.slow  # 0.5-4.5 s each: the JIT of a plastic kernel family per law and stepper
@pytest.mark.parametrize("variant,integrator", PLASTIC_SET)
def test_plastic_set_equals_refsim(variant, integrator):
    """To the run's end (the permanent set reached) at the variant's smallest dt (the
    sweep's omega dt = 0.02, else the reference 0.04): node positions and velocities within
    the trajectory bound, the committed plastic strain within it through |grad phi|, the
    same permanent_strain (measured: 2.2e-16 m against bounds of 7e-12..1.3e-11 m)."""
    p = CASE.variant_params(variant)
    dt = min(CASE.dts(p))
    steps = int(round(CASE.t_end(p) / dt))
    scene = CASE.scene(p)
    ours = run_to_end(TAICHI, scene, dt, steps, integrator)
    theirs = run_to_end(REFSIM, scene, dt, steps, integrator)
    x, y = ours.observe(), theirs.observe()
    mesh = scene.parts[0]
    system = FemSystem(mesh)
    body, el = system.body, system.body.elements
    # test_taichi_fem.py's trajectory bound: omega from refsim's (elastic) tangent at rest, the
    # largest speed the initial one (the motion only loses energy to plastic work), forces
    # of size S_a = 16 (2 mu + 3 |lam|) max(1, |F|)^5 V |grad phi_a|_1, |F| <= 1 + e_max
    jx, _ = system.jacobians(0.0, system.state()[0], system.state()[1])
    omega = float(np.sqrt(np.max(np.abs(np.linalg.eigvals(jx)))))
    e_max = CASE.constants(p)["e_max"]
    law = body.law
    s_a = 16 * (2 * law.mu + 3 * abs(law.lam)) * (1 + e_max) ** 5 * np.max(
        el.volume[:, None] * np.abs(el.grad).sum(-1))
    accel = s_a / system.masses.min()
    s_x, s_v = np.abs(y["x"]).max() * (1 + e_max), np.abs(mesh.velocities).max()
    delta = K * EPS * ((s_x + dt * dt * accel) + (s_v + dt * accel) / omega)
    growth = 2.0 * ((1 + (omega * dt) ** 2) ** (steps / 2) if integrator == "explicit_euler"
                    else 1.0)
    bound = growth * steps * delta
    assert np.abs(x["x"] - y["x"]).max() <= bound
    assert np.abs(x["v"] - y["v"]).max() <= bound * omega
    # the committed strain: each commit moves eps_p by at most twice eps's difference (the
    # return is non-expansive in eps - eps_p), eps's by 2 (1 + e_max) |grad phi|_col |dx|:
    # summed over the steps
    grad = np.abs(el.grad).sum(1).max()
    strain_bound = steps * 4 * (1 + e_max) * grad * bound
    got, _ = ours.data.plastic_state()
    assert np.abs(got - theirs.system.plastic_strain).max() <= strain_bound
    assert np.abs(theirs.system.plastic_strain).max() > 1e5 * strain_bound  # it yielded
    assert np.abs(y["x"] - mesh.positions).max() > 1e8 * bound  # it moved
    metrics = [CASE.extra_metrics(p, {"t": [s.time()]}, {"x": s.observe()["x"][None]}, None)
               for s in (ours, theirs)]
    assert abs(metrics[0]["permanent_strain"] - metrics[1]["permanent_strain"]) <= \
        (1 + e_max) * 2 * grad * bound  # F from the nodes' x
