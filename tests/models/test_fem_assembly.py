"""Tangent stiffness and mass matrices of the P1 elements (refsim.models.fem.assembly): dP/dF
and K = -df/dx against central differences, the CSR pattern found once, masses against exact
integrals."""
import numpy as np
import pytest
import scipy.sparse as sp
from ulp import assert_ulp

from refsim.models.fem.assembly import Assembler, BlockPattern, element_stiffness
from refsim.models.fem.laws import LAW_NAMES, make_law
from refsim.models.fem.meshes import box_tetrahedra, perturb_interior, rectangle_triangles
from refsim.models.fem.model import ElasticBody
from refsim.scene import Material, TetMesh, TriangleMesh

E, NU, RHO = 1.0e3, 0.3, 800.0
SETUPS = [(2, "stress"), (2, "strain"), (3, "stress")]


def body(d, plane, name, size=2):
    material = Material(E, NU, RHO, name)
    if d == 2:
        nodes, tris = rectangle_triangles(size, size, 2.0, 1.0)
        nodes = perturb_interior(nodes, 0.1, seed=11)
        return ElasticBody.of(TriangleMesh(nodes, tris, material, thickness=0.1, plane=plane))
    nodes, tets = box_tetrahedra(size, size, size, 2.0, 1.0, 1.0)
    return ElasticBody.of(TetMesh(perturb_interior(nodes, 0.1, seed=12), tets, material))


@pytest.mark.parametrize("d,plane", SETUPS)
@pytest.mark.parametrize("name", LAW_NAMES)
def test_the_closed_form_tangent_matches_central_differences_of_the_stress(d, plane, name):
    law = make_law(name, E, NU, d, plane)
    rng = np.random.default_rng(13)
    f = np.eye(d) + 0.3 * rng.standard_normal((20, d, d))
    f = f[np.linalg.det(f) > 0.2]  # away from inversion (the corotated tangent divides by
    # tr S, Neo-Hookean by nothing: both smooth there)
    h = 1e-6
    fd = np.zeros(f.shape + (d, d))
    for k, l in np.ndindex(d, d):  # test oracle: one direction at a time
        step = np.zeros((d, d))
        step[k, l] = h
        fd[..., k, l] = (law.stress(f + step) - law.stress(f - step)) / (2 * h)
    # truncation h^2/6 P''' ~ 1e-12 E, round-off eps |P| / h ~ 1e-10 E: 1e-8 E leaves 100x and
    # is 10^5 below a 0.1 % error in the tangent
    assert np.abs(law.tangent(f) - fd).max() <= 1e-8 * E
    assert np.abs(law.tangent(f)).max() > 0.3 * E


@pytest.mark.parametrize("d,plane", SETUPS)
@pytest.mark.parametrize("name", LAW_NAMES)
def test_assembled_stiffness_is_minus_the_force_jacobian_and_symmetric(d, plane, name):
    b = body(d, plane, name)
    rng = np.random.default_rng(14)
    x = b.elements.rest + 0.05 * rng.standard_normal(b.elements.rest.shape)
    k = Assembler(b).stiffness(x).toarray()
    h = 1e-6
    fd = np.zeros_like(k)
    for j in range(x.size):  # test oracle: one dof at a time
        step = np.zeros(x.size)
        step[j] = h
        fd[:, j] = -(b.forces(x + step.reshape(x.shape))
                     - b.forces(x - step.reshape(x.shape))).reshape(-1) / (2 * h)
    scale = np.abs(k).max()
    # as above: truncation (h / l)^2 and round-off eps l / h relative (l ~ 0.5), 1e-7 leaves
    # 1000x
    assert np.abs(k - fd).max() <= 1e-7 * scale
    assert_ulp(k, k.T, 64, "V G^T C G with C's major symmetry: the same products summed in "
               "two orders (up to 12 element blocks per entry)", scale=scale)


def test_the_pattern_is_found_once_and_then_only_data_is_filled():
    b = body(3, "stress", "corotated")
    assembler = Assembler(b)
    pattern = assembler.pattern
    k1 = assembler.stiffness(b.elements.rest)
    k2 = assembler.stiffness(b.elements.rest * 1.1)
    assert assembler.pattern is pattern
    for k in (k1, k2):  # the pattern's arrays shared (views), not rebuilt per call
        assert np.shares_memory(k.indices, pattern.indices)
        assert np.shares_memory(k.indptr, pattern.indptr)
    # the same matrix as scipy's COO -> CSR sum of duplicates
    blocks = element_stiffness(b.elements, b.law.tangent(b.deformation_gradient(
        b.elements.rest * 1.1)))
    dofs = pattern.element_dofs
    coo = sp.coo_matrix((blocks.reshape(-1), (np.repeat(dofs, dofs.shape[1], 1).reshape(-1),
                                               np.tile(dofs, dofs.shape[1]).reshape(-1))),
                        shape=k2.shape).tocsr()
    assert_ulp(k2.toarray(), coo.toarray(), 64, "duplicates summed in another order (up to 24 "
               "element blocks per entry)", scale=np.abs(blocks).max())


def test_a_block_pattern_of_one_dof_per_node_is_the_node_graph():
    nodes, tris = rectangle_triangles(2, 1)
    pattern = BlockPattern(tris, len(nodes), 1)
    graph = pattern.matrix(np.ones((len(tris), 3, 3))).toarray()
    assert graph[0].tolist() == [2.0, 1.0, 0.0, 1.0, 2.0, 0.0]  # node 0: two triangles


@pytest.mark.parametrize("d,plane", SETUPS)
def test_masses_integrate_linear_velocity_fields_exactly(d, plane):
    b = body(d, plane, "linear")
    assembler = Assembler(b)
    lumped, consistent = assembler.lumped_mass(RHO), assembler.consistent_mass(RHO)
    volume = 2.0 * (0.1 if d == 2 else 1.0)  # 2 x 1 (x 0.1 thick, or x 1)
    assert_ulp(lumped.sum(), RHO * volume, 64, "element volumes summed in another order")
    row_sums = np.asarray(consistent.sum(axis=1)).reshape(-1, d)
    assert_ulp(row_sums, np.repeat(lumped[:, None], d, 1), 16, "lumping is the row sum: the "
               "same element shares in another order", scale=lumped.max())
    # a rigid rotation about z, v = w e_z x X: kinetic energy 1/2 rho w^2 int (x^2 + y^2) dV
    # exactly for the consistent mass (P1 interpolates v exactly); on [0, 2] x [0, 1] (x t):
    # int x^2 + y^2 = 8/3 + 2/3 = 10/3 per unit thickness
    w = 0.7
    v = np.zeros_like(b.elements.rest)
    v[:, 0], v[:, 1] = -w * b.elements.rest[:, 1], w * b.elements.rest[:, 0]
    exact = 0.5 * RHO * w * w * 10.0 / 3.0 * (0.1 if d == 2 else 1.0)
    flat = v.reshape(-1)
    assert_ulp(0.5 * flat @ (consistent @ flat), exact, 256, "a quadrature that is exact, "
               "summed over elements in another order", scale=exact)
    lumped_energy = 0.5 * np.sum(lumped * np.sum(v * v, 1))
    assert abs(lumped_energy - exact) > 1e-3 * exact  # lumping is not exact for this field
