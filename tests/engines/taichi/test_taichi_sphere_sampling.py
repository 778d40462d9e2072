"""taichi's Witkin-Heckbert sphere sampling against refsim's model: equal to round-off, step by
step and over the whole run, for every stepper the refsim group offers on the case's default
variants; and the polyhedron reached through the harness."""
import numpy as np
import pytest

from refsim_adapters.common.first_order import SAMPLING_INTEGRATORS
from refsim_cases.first_order_fields.sphere_sampling import CASE
from refsim.integrators.first_order import get_first_order
from refsim.run.job import Job, run_job
from refsim.registry import get_engine

CPU_ARCHS = ("x64", "arm64")  # ti.cpu is taichi's x86-64 or aarch64 backend

pytest.importorskip("taichi")
EPS = np.finfo(float).eps
FD_STEP = 1e-6  # central differences: truncation ~1e-12, round-off ~eps / 1e-6 ~ 2e-10 relative


def step_map(system, stepper, p, h):
    """refsim's step: the tableau, then the projection."""
    return system.project(stepper.step(system, 0.0, p, h))


def step_jacobian(system, stepper, p, h):
    """(3n, 3n) d step_map / d p at p, every column at once (perturbations on a batch axis)."""
    n = len(p)
    basis = np.eye(3 * n).reshape(3 * n, n, 3)
    columns = (step_map(system, stepper, p + FD_STEP * basis, h) -
               step_map(system, stepper, p - FD_STEP * basis, h))
    return columns.reshape(3 * n, 3 * n).T / (2.0 * FD_STEP)


def step_difference_bound(p, stepper, h) -> float:
    """Max-abs difference of ONE step of taichi and refsim from the same positions. Both run
    the same IEEE operations in the same order except the pair sums (order), exp (1 ulp
    each side) and the 3-term dots: a slope differs by <= (n + 4) eps G, G = (2 alpha /
    sigma) (n - 1) e^(-1/2) the largest pair sum (x e^(-x^2 / 2 sigma^2) <= sigma e^(-1/2)).
    A slope difference reaches later stages through h a_sj and u's Lipschitz constant
    L <= sqrt(3) ((2 alpha / sigma^2) 2 (n - 1) + 2 G / R) (max-abs norm of 3x3 blocks), so
    the step differs by h |b|^T (I - h L |A|)^-1 1 (n + 4) eps G, plus 2 eps R for the
    projection's 3-term norm."""
    n, sigma, alpha, radius = CASE.count(p), p["sigma"], p["alpha"], 1.0
    pair_sum = (2.0 * alpha / sigma) * (n - 1) * np.exp(-0.5)
    lipschitz = np.sqrt(3.0) * ((2.0 * alpha / sigma ** 2) * 2 * (n - 1) +
                                2.0 * pair_sum / radius)
    a, b, _ = stepper.tableau.arrays()
    stages = np.linalg.solve(np.eye(len(b)) - h * lipschitz * np.abs(a), np.ones(len(b)))
    slope_gain = h * float(np.abs(b) @ stages)
    return EPS * (2.0 * radius + slope_gain * (n + 4) * pair_sum)


def refsim_run_with_tangents(p, stepper, h, steps, taichi_sim):
    """refsim's trajectory; at each of its states the largest difference of one taichi step
    from it, and sum_k |Phi_(k+1 -> K)|_inf (Phi the product of the later steps' Jacobians):
    the factor a per-step difference delta becomes at the end, to first order in delta."""
    system = CASE.system(p)
    x = system.project(CASE.start(p))
    jacobians, one_step = [], 0.0
    for _ in range(steps):
        jacobians.append(step_jacobian(system, stepper, x, h))
        taichi_sim.p[...] = x  # the kernel array, written in place
        taichi_sim.step(1)
        x = step_map(system, stepper, x, h)
        one_step = max(one_step, float(np.max(np.abs(taichi_sim.p - x))))
    later, gain = np.eye(len(jacobians[0])), 1.0  # the last step's own difference: Phi = I
    for jacobian in reversed(jacobians[1:]):
        later = later @ jacobian
        gain += float(np.max(np.sum(np.abs(later), axis=1)))
    return x, one_step, gain


@pytest.mark.parametrize("variant", CASE.default_variants)
@pytest.mark.parametrize("integrator", SAMPLING_INTEGRATORS)
def test_taichi_equals_refsim_to_roundoff(variant, integrator):
    """Each step from refsim's state within the one-step bound delta, and the whole run within
    delta sum_k |Phi_(k+1 -> K)| (the rigid rotations are neutral, the rest contracts near
    the polyhedron: the sum stays ~steps x 2, not exp(L t))."""
    p = CASE.variant_params(variant)
    stepper, h = get_first_order(integrator), CASE.dts(p)[0]
    steps = round(CASE.t_end(p) / h)
    engine = get_engine("taichi")
    lockstep = engine.build(CASE.scene(p), h, integrator)
    final, one_step, gain = refsim_run_with_tangents(p, stepper, h, steps, lockstep)
    delta = step_difference_bound(p, stepper, h)
    assert one_step <= delta
    whole = engine.build(CASE.scene(p), h, integrator)
    whole.step(steps)
    refsim = get_engine("refsim").build(CASE.scene(p), h, integrator)
    refsim.step(steps)
    taichi_x, refsim_x = whole.observe()["x"], refsim.observe()["x"]
    # the trajectory the tangents were taken on; same operations: the refsim engine's
    # stepper.step then project on the same system (autonomous: its t is unused)
    assert np.array_equal(refsim_x, final)
    assert np.max(np.abs(taichi_x - refsim_x)) <= delta * gain
    assert np.allclose(np.linalg.norm(taichi_x, axis=1), 1.0, rtol=0.0, atol=2 * EPS)


@pytest.mark.parametrize("variant", CASE.default_variants)
@pytest.mark.parametrize("integrator", SAMPLING_INTEGRATORS)
def test_taichi_reaches_the_polyhedron(variant, integrator):
    """Through the harness: err_final (the angle error as the case computes it) within the
    case's derived tolerance, the energy never rising by more than its n^2 eps round-off."""
    p = CASE.variant_params(variant)
    row = run_job(Job(CASE.name, variant, "taichi", "", integrator, CASE.dts(p)[0]),
                  repeats=0)
    assert row["status"] == "ok" and (row["consistency"] == "consistent"), row["tol_reason"]
    assert row["polyhedron"] == variant
    assert row["energy_rise"] <= CASE.count(p) ** 2 * EPS


def test_refusals_and_settings():
    engine = get_engine("taichi")
    scene = CASE.scene(CASE.variant_params("tetrahedron"))
    assert "implicit_euler" not in SAMPLING_INTEGRATORS
    offered = f"offered here: {list(SAMPLING_INTEGRATORS)}"
    assert offered in engine.supports(scene, "implicit_euler")  # no affine field to solve
    assert "needs x'' = a" in engine.supports(scene, "velocity_verlet")
    sim = engine.build(scene, 0.05, "heun")
    settings = sim.settings()
    assert settings["dtype"] == "float64" and settings["default_fp"].endswith("f64")
    assert settings["arch"] in CPU_ARCHS and settings["threads"] == 1
    assert settings["integrator"]["order"] == 2 and "after every step" in settings["projection"]
    observed = sim.observe()
    assert set(observed) == {"t", "x", "v", "repulsion_energy"}
    in_house = get_engine("refsim").build(scene, 0.05, "heun").observe()
    for name in observed:  # the same start, the same numpy model: bit for bit at t = 0
        assert np.array_equal(observed[name], in_house[name])


@pytest.mark.parametrize("variant", list(CASE.variants))
def test_velocity_kernel_matches_the_model(variant):
    """u at the random start (the whole sphere, every pair distance): the pair sum's order
    and exp's last bit only, (n + 4) eps G (`step_difference_bound`'s slope term)."""
    from refsim_adapters.taichi_engine import sampling_kernels as sk
    from refsim_adapters.taichi_engine.kernel_store import to_ndarray
    p = CASE.variant_params(variant)
    system, n = CASE.system(p), CASE.count(p)
    start = system.project(CASE.start(p))
    positions, velocities = to_ndarray(start), to_ndarray(np.zeros_like(start))
    sk.velocities(positions, velocities, sk.sampling_pack(1.0, (0.0, 0.0, 0.0), p["sigma"],
                                                          p["alpha"]))
    pair_sum = (2.0 * p["alpha"] / p["sigma"]) * (n - 1) * np.exp(-0.5)
    assert np.max(np.abs(velocities - system.velocity(0.0, start))) <= \
        (n + 4) * EPS * pair_sum
