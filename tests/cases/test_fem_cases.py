"""The static FEM cases on the in-house engine: every variant within its static-solve bound,
and the bound tight enough to catch a wrong stiffness or the slides' printed nodal force."""
import numpy as np
import pytest

from refsim.models.fem.elements import slide_printed_forces
from refsim.models.fem.model import ElasticBody
from refsim.models.fem.static import solve_static
from refsim.registry import get_case
from refsim.run.job import Job, run_job
from refsim.scene import Material, TriangleMesh

CASES = {"patch_test": ("linear", "green", "corotated", "neo_hookean", "tet_corotated",
                        "tet_neo_hookean"),
         "uniaxial_stretch": ("corotated", "green", "linear", "green_mujoco_probe")}


@pytest.mark.parametrize("name, variant", [(c, v) for c, vs in CASES.items() for v in vs])
def test_static_solve_within_its_bound(name, variant):
    row = run_job(Job(name, variant, "refsim", "", "steady", 1.0), repeats=0)
    assert row["status"] == "ok" and row["consistency"] == "consistent", row["reason"]
    assert row["err_max"] <= row["tolerance"]


def test_stretch_meets_the_closed_forms_and_mujocos_probe():
    """StVK's root for E = 1000, t = 0.1, F = 10 on a unit square: 1.0880339 (MuJoCo 4's flex
    settles at 1.088034); corotated and linear 1 + F / (E t H)."""
    case = get_case("uniaxial_stretch")
    row = run_job(Job("uniaxial_stretch", "green_mujoco_probe", "refsim", "", "steady", 1.0),
                  repeats=0)
    assert row["stretch_exact"] == pytest.approx(1.0880339, abs=5e-8)
    assert row["stretch"] == pytest.approx(row["stretch_exact"], rel=1e-12)
    p = case.variant_params("corotated")
    assert case._lambda(p) == pytest.approx(1.0 + 2.0 / (1000.0 * 0.1 * 0.2), rel=1e-15)


def _with_material(mesh, **changes):
    m = mesh.material
    material = Material(changes.get("youngs_modulus", m.youngs_modulus), m.poisson_ratio,
                        m.density, m.strain)
    return TriangleMesh(mesh.vertices, mesh.triangles, material, thickness=mesh.thickness,
                        plane=mesh.plane, pinned=mesh.pinned, loads=mesh.loads,
                        positions=mesh.positions)


@pytest.mark.parametrize("variant", ["corotated", "green"])
def test_a_stiffness_0_1_percent_off_fails_the_stretch_bound(variant):
    """An engine whose E is 0.1 % high stretches the strip 0.1 % less: 1e5 x the bound."""
    case = get_case("uniaxial_stretch")
    p = case.variant_params(variant)
    mesh = _with_material(case.mesh(p), youngs_modulus=1.001 * p["youngs_modulus"])
    body = ElasticBody.of(mesh)
    fixed = np.zeros((len(mesh), 2), bool)
    fixed[mesh.pinned] = True
    solved = solve_static(body, body.to_local(mesh.loads), fixed, rtol=1e-12)
    x = body.to_world(solved.x)
    error = np.linalg.norm(x - case.exact(p))
    bound = case.tolerance(p, "steady", 0, 1.0)[0]
    assert error > 1e3 * bound, (error, bound)


def test_the_slides_printed_force_fails_the_patch_test():
    """f_i = Q sigma n_i with unit normals (slide 001 as printed), applied as a nodal force,
    leaves the linear field's interior nodes pushed: an equilibrium x of those forces sits at
    least |r| / lambda_max(K) from the field (r: their residual at the field), far past the
    patch test's bound; the correct force's residual, through 1 / lambda_min, stays within it."""
    case = get_case("patch_test")
    p = case.variant_params("linear")
    mesh = case.mesh(p)
    body = ElasticBody.of(mesh)
    exact = body.to_local(case.exact(p))
    stress = body.stress(exact)
    interior = np.setdiff1d(np.arange(len(mesh)), mesh.pinned)
    printed = body.elements.gather(slide_printed_forces(body.elements, stress))[interior]
    correct = body.forces(exact)[interior]
    from refsim_cases.fem._static import free_stiffness_extremes
    lam_min, lam_max = free_stiffness_extremes(mesh, case.exact(p))
    bound = case.tolerance(p, "steady", 0, 1.0)[0]
    # a residual r moves the solution by at least |r| / lambda_max
    assert np.linalg.norm(printed) / lam_max > 1e6 * bound
    assert np.linalg.norm(correct) / lam_min <= bound
