"""P1 elements and their laws against closed forms: the patch test, rigid rotation, slide
001's printed nodal force beside the correct one, and plane strain against a prism of
tetrahedra (refsim.models.fem.elements, fem_laws, fem_model)."""
import numpy as np
import pytest
from ulp import EPS, assert_ulp

from refsim.models.fem.elements import Elements, slide_printed_forces
from refsim.models.fem.laws import LAW_NAMES, make_law
from refsim.models.fem.meshes import (box_tetrahedra, perturb_interior, prism_tetrahedra,
                                      rectangle_triangles)
from refsim.models.fem.model import ElasticBody
from refsim.scene import Material, TetMesh, TriangleMesh

E, NU = 1.0e3, 0.3
SETUPS = [(2, "stress"), (2, "strain"), (3, "stress")]


def irregular_mesh(d):
    """(elements, interior node mask): a jittered 4 x 4 square (d = 2, thickness 0.1) or
    3 x 3 x 3 cube (d = 3), interior nodes moved by up to 0.2 x the cell size."""
    if d == 2:
        nodes, cells = rectangle_triangles(4, 4)
        rest = perturb_interior(nodes, 0.05, seed=1)[:, :2]
    else:
        nodes, cells = box_tetrahedra(3, 3, 3)
        rest = perturb_interior(nodes, 0.05, seed=2)
    inner = np.all((rest > 0) & (rest < 1), axis=1)
    return Elements(rest, cells, thickness=0.1), inner


def valence(elements):
    return int(np.bincount(elements.cells.reshape(-1)).max())


def position_bound(elements, x, scale):
    """Round-off of F = Ds Dm^-1 in units of eps x scale: the positions carry eps |x|, their
    differences over the shortest edge h give eps |x| / h, and Dm^-1 adds cond(Dm) eps;
    factor 4 for the few roundings in each product."""
    h = np.min(np.linalg.norm(elements.dm, axis=1))
    cond = np.max(np.linalg.cond(elements.dm))
    return 4.0 * (np.max(np.abs(x)) / (h * scale) + cond)


@pytest.mark.parametrize("d,plane", SETUPS)
@pytest.mark.parametrize("name", LAW_NAMES)
def test_patch_test_a_linear_field_gives_the_constant_stress_and_no_interior_force(d, plane,
                                                                                   name):
    elements, inner = irregular_mesh(d)
    rng = np.random.default_rng(3)
    a = np.eye(d) + 0.3 * rng.standard_normal((d, d))  # stretch, shear and rotation
    x = elements.rest @ a.T + rng.standard_normal(d)
    f = elements.deformation_gradient(x)
    ulps_f = position_bound(elements, x, np.abs(a).max())
    assert_ulp(f, np.broadcast_to(a, f.shape), ulps_f, "F = Ds Dm^-1 of an affine field is A "
               "to the round-off of the positions and of Dm^-1 (position_bound)",
               scale=np.abs(a).max())
    law = make_law(name, E, NU, d, plane)
    p, p0 = law.stress(f), law.stress(a[None])[0]
    c_scale = d * d * np.abs(law.tangent(a[None])).max() * np.abs(a).max()
    assert_ulp(p, np.broadcast_to(p0, p.shape), 2 * ulps_f, "dP = C : dF carries F's round-off "
               "(position_bound) through the tangent C; factor 2 for the law's own roundings",
               scale=c_scale)
    per_element = elements.element_forces(p)
    forces = elements.gather(per_element)
    bound = valence(elements) * 2 * ulps_f * EPS * np.abs(per_element).max()
    # an interior node sums `valence` element forces that cancel exactly; each carries its
    # stress's round-off (above)
    assert np.abs(forces[inner]).max() <= bound
    assert np.abs(forces[~inner]).max() > 1e3 * bound  # the boundary carries the load


@pytest.mark.parametrize("d,plane", SETUPS)
@pytest.mark.parametrize("name", ["green", "corotated", "neo_hookean"])
@pytest.mark.parametrize("theta", [0.3, 2.0])
def test_rigid_rotation_gives_no_force_for_the_rotation_invariant_laws(d, plane, name, theta):
    elements, _ = irregular_mesh(d)
    law = make_law(name, E, NU, d, plane)
    rot = rotation(d, theta)
    x = elements.rest @ rot.T + 0.5
    per_element = elements.element_forces(law.stress(elements.deformation_gradient(x)))
    scale = d * d * np.abs(law.tangent(np.eye(d)[None])).max() * np.max(
        elements.volume[:, None] * np.linalg.norm(elements.grad, axis=2))
    bound = valence(elements) * 2 * position_bound(elements, x, 1.0) * EPS * scale
    # F = R to round-off (position_bound); P(R + dF) = C : dF; forces V P grad phi summed
    assert np.abs(elements.gather(per_element)).max() <= bound
    assert np.abs(per_element).max() <= bound


def rotation(d, theta):
    c, s = np.cos(theta), np.sin(theta)
    r2 = np.array([[c, -s], [s, c]])
    if d == 2:
        return r2
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + s * k + (1 - c) * k @ k  # Rodrigues


@pytest.mark.parametrize("theta", [1e-3, 0.3, 2.0])
def test_cauchy_strain_of_a_rigid_rotation_is_cos_theta_minus_one_and_pushes_the_nodes(theta):
    # one right triangle, legs a (x) and b (y), thickness t: grad phi_0 = (-1/a, -1/b),
    # grad phi_1 = (1/a, 0), grad phi_2 = (0, 1/b), V = a b t / 2; P = c I with
    # c = (2 mu + 2 lam*)(cos theta - 1) (plane stress lam* = E nu / (1 - nu^2)), so
    # f_a = -V P grad phi_a: f_0 = c t (b, a) / 2, f_1 = -c t (b, 0) / 2, f_2 = -c t (0, a) / 2
    a, b, t = 2.0, 0.5, 0.1
    elements = Elements([[0.0, 0.0], [a, 0.0], [0.0, b]], [[0, 1, 2]], thickness=t)
    law = make_law("linear", E, NU, 2, "stress")
    x = elements.rest @ rotation(2, theta).T
    f = elements.deformation_gradient(x)
    cos_m1 = -2.0 * np.sin(theta / 2) ** 2  # cos theta - 1 without cancellation
    assert_ulp(law.strain(f)[0], cos_m1 * np.eye(2), 8, "1/2 (F + F^T) - I cancels to "
               "cos theta - 1: its round-off is a few eps of |F| = 1, not of the result",
               scale=1.0)
    mu, lam = E / (2 * (1 + NU)), E * NU / (1 - NU ** 2)
    c = (2 * mu + 2 * lam) * cos_m1
    want = c * t / 2 * np.array([[b, a], [-b, 0.0], [0.0, -a]])
    got = elements.nodal_forces(law.stress(f))
    assert_ulp(got, want, 16, "the strain's few eps of 1 (above) times 2 mu + 2 lam, through "
               "V P grad phi", scale=(2 * mu + 2 * lam) * t * max(a, b))
    assert np.abs(got).max() > 0.1 * np.abs(c) * t * b  # the spurious force is there


def test_cauchy_rotation_force_in_3d_matches_its_closed_form():
    # about a unit axis n, R = I + sin theta K + (1 - cos theta) K^2, so the Cauchy strain is
    # (cos theta - 1)(I - n n^T): (cos theta - 1) in the rotation plane, 0 along the axis;
    # P = 2 mu eps + lam tr(eps) I. One right tetrahedron, legs a, b, c along x, y, z:
    # V = a b c / 6, grad phi_k = e_k / leg_k, so f_k = -V P e_k / leg_k, f_0 = -sum
    a, b, c = 1.0, 2.0, 0.5
    rest = np.array([[0.0, 0, 0], [a, 0, 0], [0, b, 0], [0, 0, c]])
    elements = Elements(rest, [[0, 1, 2, 3]])
    law = make_law("linear", E, NU, 3)
    theta, axis = 0.7, np.array([1.0, 2.0, 2.0]) / 3.0
    x = rest @ rotation(3, theta).T
    mu, lam = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))
    eps = -2.0 * np.sin(theta / 2) ** 2 * (np.eye(3) - np.outer(axis, axis))
    p = 2 * mu * eps + lam * np.trace(eps) * np.eye(3)
    legs = -(a * b * c / 6) * (p / np.array([a, b, c])).T  # row k: -V P e_k / leg_k
    want = np.concatenate([-legs.sum(0, keepdims=True), legs])
    got = elements.nodal_forces(law.stress(elements.deformation_gradient(x)))
    assert_ulp(got, want, 32, "the strain's few eps of |F| = 1 (cancellation in 1/2 (F + F^T)"
               " - I) times 2 mu + 3 lam, through V P grad phi", scale=(2 * mu + 3 * lam) * b)
    assert np.abs(got).max() > 10.0  # the spurious force: 0.24 E-scale stress on the legs


def test_the_slides_printed_force_drops_the_face_weights_and_pushes_a_stretched_element():
    # a right triangle, legs a (x) and b (y), thickness t, stretched uniformly: the correct
    # forces are the face weights t |e_i| / 2 times P n_i and sum to zero; the printed
    # f_i = P n_i sums to P (n_0 + n_1 + n_2) with n_0 = (b, a) / hyp, n_1 = (-1, 0),
    # n_2 = (0, -1): a net force on a uniformly stressed element
    a, b, t = 1.0, 3.0, 0.1
    elements = Elements([[0.0, 0.0], [a, 0.0], [0.0, b]], [[0, 1, 2]], thickness=t)
    law = make_law("corotated", E, 0.0, 2, "stress")
    lam_x = 1.1
    p = law.stress(elements.deformation_gradient(elements.rest * [lam_x, 1.0]))
    correct = elements.element_forces(p)[0]
    printed = slide_printed_forces(elements, p)[0]
    hyp = np.hypot(a, b)
    weights = t / 2 * np.array([hyp, b, a])
    assert_ulp(correct, weights[:, None] * printed, 8, "the same product V |grad phi| P n "
               "in two orders", scale=np.abs(correct).max())
    assert np.abs(correct.sum(0)).max() <= 8 * EPS * np.abs(correct).max()  # cancels
    net = p[0] @ (np.array([b, a]) / hyp + [-1.0, 0.0] + [0.0, -1.0])
    assert_ulp(printed.sum(0), net, 8, "three unit normals summed in another order",
               scale=np.abs(p).max())
    # nu = 0: P = diag(E (lambda - 1), 0), so the printed net force is
    # (E (lambda - 1)(b / hyp - 1), 0): 5.1 N/m^2 here, where the correct net force is 0
    assert_ulp(net, [E * (lam_x - 1) * (b / hyp - 1), 0.0], 16, "P11 = E (lambda - 1) to a "
               "few eps (the SVD's round-off) times a sum of three normals",
               scale=E * (lam_x - 1))
    assert abs(net[0]) > 5.0


@pytest.mark.parametrize("name", LAW_NAMES)
def test_plane_strain_triangles_equal_a_prism_of_tetrahedra(name):
    # a plane deformation of a prism (the same in-plane motion on both layers) is linear on
    # each tetrahedron of the prism: F_tet = diag(F_tri, 1) exactly, so the energies agree
    # and each triangle node's force is the sum of its two layer nodes' in-plane forces
    nodes, tris = rectangle_triangles(3, 2, 1.5, 1.0)
    nodes = perturb_interior(nodes, 0.05, seed=4)
    t = 0.2
    tri = ElasticBody.of(TriangleMesh(nodes, tris, Material(E, NU, 1.0, name), thickness=t,
                                      plane="strain"))
    tet_nodes, tets = prism_tetrahedra(nodes, tris, t)
    tet = ElasticBody.of(TetMesh(tet_nodes, tets, Material(E, NU, 1.0, name)))
    rng = np.random.default_rng(5)
    x2 = nodes[:, :2] + 0.1 * rng.standard_normal((len(nodes), 2))
    x3 = tet_nodes.copy()
    x3[:, :2] = np.concatenate([x2, x2])
    f2, f3 = tri.forces(x2), tet.forces(x3)
    n = len(nodes)
    scale = np.abs(f2).max()
    assert_ulp(f3[:n, :2] + f3[n:, :2], f2, 64 * valence(tet.elements), "the same stresses "
               "(to the law's round-off) summed over the prism's tetrahedra in another order",
               scale=scale)
    assert_ulp(tet.energy(x3), tri.energy(x2), 64, "sum over elements in another order")
    assert scale > 1e-2 * E * t  # a real deformation
