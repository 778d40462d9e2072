"""Slide 001's printed nodal force as a body (refsim.models.fem.printed): its forces, its
Jacobian, and the in-house engine's `as_printed` formulation caught by the FEM cases."""
from __future__ import annotations

import numpy as np
import pytest
from ulp import EPS, assert_ulp

from refsim.models.fem.elements import slide_printed_forces
from refsim.models.fem.meshes import box_tetrahedra, perturb_interior, rectangle_triangles
from refsim.models.fem.model import ElasticBody
from refsim.models.fem.printed import (FORMULATION, PrintedAssembler, PrintedForceBody,
                                       body_and_assembler)
from refsim.models.fem.system import FemSystem
from refsim.run.job import Job, run_job
from refsim.scene import Material, TetMesh, TriangleMesh

E, NU = 1.0e3, 0.3


def _mesh(d, strain="green"):
    material = Material(E, NU, 1.0, strain)
    if d == 2:
        nodes, cells = rectangle_triangles(3, 3)
        return TriangleMesh(perturb_interior(nodes, 0.05, seed=3), cells, material,
                            thickness=0.1, pinned=[0])
    nodes, cells = box_tetrahedra(2, 2, 2)
    return TetMesh(perturb_interior(nodes, 0.1, seed=3), cells, material, pinned=[0])


def _deformed(body, seed):
    rng = np.random.default_rng(seed)
    x = body.elements.rest
    return x + 0.05 * rng.standard_normal(x.shape)


@pytest.mark.parametrize("d", [2, 3])
def test_printed_forces_are_the_slides_formula_summed_into_nodes(d):
    body = PrintedForceBody.of(_mesh(d))
    x = _deformed(body, 1)
    per_node = slide_printed_forces(body.elements, body.stress(x))  # P n_i, unit normals
    expected = body.elements.gather(per_node)
    # the body divides -V P grad phi_i by w_i = V |grad phi_i|; the slide's function takes P
    # times grad phi_i / |grad phi_i|: the same quotient in another order, a few ulps of the
    # largest force per term, summed over a node's star (valence <= 8 in 2D, 24 in 3D)
    assert_ulp(body.forces(x), expected, 64, "the same quotient in two orders, summed over "
               "a node's star", scale=np.abs(expected).max())
    correct = ElasticBody.forces(body, x)
    assert np.abs(body.forces(x) - correct).max() > 0.1 * np.abs(correct).max()


@pytest.mark.parametrize("d", [2, 3])
def test_printed_jacobian_is_minus_the_derivative_of_the_printed_forces(d):
    body, assembler = body_and_assembler(_mesh(d), FORMULATION)
    assert isinstance(assembler, PrintedAssembler)
    x = _deformed(body, 2)
    k = assembler.stiffness(x).toarray()
    h = 1e-6  # central differences: truncation h^2 |f'''| ~ 1e-12 relative, round-off
    #           eps |f| / h ~ 1e-10 relative: agreement to 1e-7 of the largest entry
    numeric = np.empty_like(k)
    flat = x.reshape(-1)
    for col in range(flat.size):
        step = np.zeros_like(flat)
        step[col] = h
        plus = body.forces((flat + step).reshape(x.shape)).reshape(-1)
        minus = body.forces((flat - step).reshape(x.shape)).reshape(-1)
        numeric[:, col] = -(plus - minus) / (2 * h)
    assert np.abs(k - numeric).max() <= 1e-7 * np.abs(k).max()
    # not the Hessian of an energy: the rows of a node are divided by its face weights
    assert np.abs(k - k.T).max() > 1e-3 * np.abs(k).max()
    correct = body_and_assembler(_mesh(d))[1].stiffness(x).toarray()
    assert np.abs(correct - correct.T).max() <= 64 * EPS * np.abs(correct).max()


def test_unknown_formulation_is_refused_with_the_valid_ones():
    with pytest.raises(ValueError, match="formulation must be '' or 'as_printed'"):
        body_and_assembler(_mesh(2), "printed")


def test_the_system_takes_the_printed_forces_and_says_so():
    system = FemSystem(_mesh(2), formulation=FORMULATION)
    assert "f_i = Q sigma n_i" in system.describe()["nodal_force"]
    assert "nodal_force" not in FemSystem(_mesh(2)).describe()


@pytest.mark.parametrize("case,variant", [("patch_test", "linear"),
                                          ("patch_test", "tet_corotated"),
                                          ("uniaxial_stretch", "corotated")])
def test_the_fem_cases_catch_the_printed_force(case, variant):
    """The correct force passes; the printed one is inconsistent with the static solve's
    bound (the patch test's irregular interior nodes: unequal faces around them; the strip:
    edge loads in N against forces in N/m^2, w = t h / 2 = 0.0125 m^2 on its edges)."""
    right = run_job(Job(case, variant, "refsim", "", "steady", 1.0), repeats=0)
    printed = run_job(Job(case, variant, "refsim", FORMULATION, "steady", 1.0), repeats=0)
    assert right["consistency"] == "consistent", right["consistency_reason"]
    assert printed["status"] == "ok" and printed["consistency"] == "inconsistent"
    assert printed["err_max"] > 1e6 * printed["tolerance"]
    assert "f_i = Q sigma n_i" in printed["settings"]
    if case == "uniaxial_stretch":
        # the edge stress balances F / w instead of F: the strip barely stretches
        assert printed["stretch"] - 1.0 < 0.05 * (printed["stretch_exact"] - 1.0)
