"""The FEM explicit force path written entry by entry (refsim.models.fem.elements' sparse maps,
the laws' component-wise stresses, FemSystem.accel's composed maps) against the matrix forms it
replaced, which stay in the package or are written out here: batched matmuls for F and the
element forces, the incidence-matrix gather, the laws' matrix formulas (the corotated one
through `_polar`), forces / masses in world coordinates.

Round-off bounds. The two sides sum the same terms in another order and round different
intermediate values, so they agree to a few roundings of the terms' size, never bit for bit
(except where stated: the edge vectors are the same single subtraction):
- stress: every term of a law's P is at most sigma_e = 16 (2 mu + 3 |lam|) max(1, |F|)^5
  (tests/engines/taichi/test_taichi_fem.py's bound: a 3x3 determinant's 6 products times a
  cofactor's 2), and each side rounds an entry at most ~16 times (F's products, the scalar
  factors, a matmul's or LAPACK's sums), each of relative size eps: 32 eps sigma_e;
- nodal forces: node a sums at most valence x d terms of size V |grad phi_a|_1 |P|; each side
  rounds each term d + 2 times (the product, Dm^-T's sum or the precomputed -V grad phi) and
  the node's sum valence x d times: (valence + 2) d eps S_a, S_a = sum_e V_e |grad phi_a|_1
  max|P_e|;
- accelerations: the forces' bound with the stress's round-off carried through (32 eps
  sigma_e per element), plus the division by the mass, the loads (an eps of f_ext / m) and, for
  a mesh in a tilted plane, the plane coordinates' round-off (eps |x| per coordinate, over the
  shortest edge h: a factor 1 + 4 |x| / h on the stress scale, position_bound's reason).
"""
import numpy as np
import pytest

from refsim.models.fem.elements import Elements, edge_matrices
from refsim.models.fem.laws import (LAW_NAMES, cofactor, make_law, plane_corotated_stress,
                                   rotation_variant_svd)
from refsim.models.fem.meshes import box_tetrahedra, perturb_interior, rectangle_triangles
from refsim.models.fem.polar import newton_polar
from refsim.models.fem.system import FemSystem
from refsim.models.fem.tensors import by_components, components
from refsim.scene import Material, TetMesh, TriangleMesh

EPS = np.finfo(float).eps
KINDS = ("stress", "strain", "tet")  # plane-stress and plane-strain triangles, tetrahedra


def matrix_stress(law, f):
    """The laws' matrix formulas (the stresses before they were written entry by entry)."""
    inner = getattr(law, "law", law)  # plane strain: the 3D law on diag(F, 1)
    if inner is not law:
        pad = np.zeros(f.shape[:-2] + (3, 3))
        pad[..., :2, :2], pad[..., 2, 2] = f, 1.0
        return matrix_stress(inner, pad)[..., :2, :2]
    d, mu, lam = f.shape[-1], law.mu, law.lam
    eye = np.eye(d)
    if law.name == "linear":
        eps = 0.5 * (f + np.swapaxes(f, -1, -2)) - eye
        return 2 * mu * eps + lam * np.trace(eps, axis1=-2, axis2=-1)[..., None, None] * eye
    if law.name == "green":
        e = 0.5 * (np.swapaxes(f, -1, -2) @ f - eye)
        return f @ (2 * mu * e + lam * np.trace(e, axis1=-2, axis2=-1)[..., None, None] * eye)
    if law.name == "corotated":
        r, s, _ = law._polar(f)
        return 2 * mu * (f - r) + lam * (np.sum(s, -1) - d)[..., None, None] * r
    ic, j = np.sum(f * f, axis=(-2, -1)), np.linalg.det(f)
    return ((mu * (1 - 1 / (ic + 1)))[..., None, None] * f
            + (lam * (j - law.alpha))[..., None, None] * cofactor(f))


def stress_scale(law, f):
    """sigma_e (module docstring), (m,)."""
    inner = getattr(law, "law", law)
    return 16 * (2 * inner.mu + 3 * abs(inner.lam)) * np.maximum(
        1.0, np.abs(f).max(axis=(-2, -1))) ** 5


def random_gradients(d, m=400, seed=0, spread=0.4):
    """(m, d, d): rotations of I + spread N (N standard normal), det > 0 kept."""
    rng = np.random.default_rng(seed)
    f = np.eye(d) + spread * rng.standard_normal((m, d, d))
    q, _ = np.linalg.qr(rng.standard_normal((m, d, d)))
    q[np.linalg.det(q) < 0, :, 0] *= -1.0
    f = q @ f
    return f[np.linalg.det(f) > 0.05]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("name", LAW_NAMES)
def test_component_stress_equals_the_matrix_form(kind, name):
    law = make_law(name, 1000.0, 0.3, 3 if kind == "tet" else 2,
                   "strain" if kind == "strain" else "stress")
    f = random_gradients(law.d, seed=LAW_NAMES.index(name))
    by_comp = by_components(law.d, (len(f),))
    by_comp[...] = f
    got, layout = law.stress(f), law.stress(by_comp)
    assert np.array_equal(got, layout)  # the same operations on either memory layout
    want = matrix_stress(law, f)
    bound = 32 * EPS * stress_scale(law, f)[:, None, None]
    assert np.all(np.abs(got - want) <= bound), np.max(np.abs(got - want) / bound)
    assert np.abs(want).max() > 1e9 * bound.max()  # stresses far above the bound
    if kind == "strain" and name != "corotated":  # in-plane entries: the padded 3D values
        np.testing.assert_array_equal(got, law.law.stress(law._pad(f, 1.0))[..., :2, :2])


def test_corotated_stress_of_a_collapsed_element_takes_r_equal_to_the_identity():
    # tr(R^T F) = r = 0 for F = [[a, b], [b, -a]]: no rotation is preferred, R = I (as _polar)
    law = make_law("corotated", 1000.0, 0.3, 2)
    f = np.array([[[0.3, 0.2], [0.2, -0.3]], [[1.0, 0.0], [0.0, 1.0]]])
    want = matrix_stress(law, f)
    assert np.all(np.abs(law.stress(f) - want) <= 32 * EPS * stress_scale(law, f)[:, None, None])
    assert np.all(np.isfinite(law.stress(f)))


def test_plane_strain_corotated_takes_the_closed_form_where_det_f_is_positive():
    # det F > 0: diag(F, 1) = diag(R, 1) diag(S, 1) is THE polar decomposition, so the 3D
    # law's stress is the 2D closed form with the 3D constants (round-off apart); det F <= 0
    # (inverted, with sigma_2 above and below 1, and collapsed): the 3D SVD on those elements,
    # the same operations as the matrix form
    law = make_law("corotated", 1000.0, 0.3, 2, "strain")
    upright = random_gradients(2, seed=7)
    flipped = np.array([[[2.0, 0.0], [0.0, -1.5]], [[0.5, 0.1], [0.0, -0.3]],
                        [[1.0, 2.0], [0.5, 1.0]]])  # det -3, -0.15, 0
    f = np.concatenate([upright, flipped])
    got, want = law.stress(f), matrix_stress(law, f)
    bound = 32 * EPS * stress_scale(law, f)[:, None, None]
    assert np.all(np.abs(got - want)[:-3] <= bound[:-3])
    assert np.array_equal(got[-3:], want[-3:])
    closed = plane_corotated_stress(flipped[:2], law.mu, law.lam)
    assert np.abs(closed - want[-3:-1]).max() > 100.0  # the flipped z axis matters there


def irregular(d, seed=1):
    if d == 2:
        nodes, cells = rectangle_triangles(5, 4, 1.0, 0.8)
        return Elements(perturb_interior(nodes, 0.04, seed=seed)[:, :2], cells, 0.1)
    nodes, cells = box_tetrahedra(3, 2, 2)
    return Elements(perturb_interior(nodes, 0.06, seed=seed), cells)


@pytest.mark.parametrize("d", [2, 3])
def test_edges_and_deformation_gradient_equal_the_matmul_route(d):
    elements = irregular(d)
    rng = np.random.default_rng(4)
    x = elements.rest @ (np.eye(d) + 0.3 * rng.standard_normal((d, d))).T + 5.0
    ds = np.swapaxes(edge_matrices(x, elements.cells), 1, 2)  # rows: edges x_k - x_0
    edges = (elements.edge_map @ x.reshape(-1)).reshape(d, d, -1)
    assert np.array_equal(np.moveaxis(edges, -1, 0), np.swapaxes(ds, 1, 2))  # one rounding
    got = elements.deformation_gradient(x)
    want = edge_matrices(x, elements.cells) @ elements.dm_inv
    scale = np.abs(edge_matrices(x, elements.cells)) @ np.abs(elements.dm_inv)
    # an entry is a sum of d products: d roundings of the terms' size on either side
    assert np.all(np.abs(got - want) <= 2 * d * EPS * scale)


@pytest.mark.parametrize("d", [2, 3])
def test_nodal_forces_equal_the_gathered_element_forces(d):
    elements = irregular(d)
    p = np.random.default_rng(5).standard_normal((elements.m, d, d)) * 1e3
    got = elements.nodal_forces(p)
    want = elements.gather(elements.element_forces(p))
    valence = np.bincount(elements.cells.reshape(-1)).max()
    s_a = elements.gather((elements.volume[:, None] * np.abs(elements.grad).sum(-1))
                          * np.abs(p).max(axis=(1, 2))[:, None])
    bound = (valence + 2) * d * EPS * s_a[:, None]
    assert np.all(np.abs(got - want) <= bound), np.max(np.abs(got - want) / bound)
    assert np.abs(want).max() > 1e9 * bound.max()


def mesh_of(kind, law, tilt=False, seed=0):
    """A small irregular mesh, x = 0 pinned, deformed and moving, with loads; `tilt` turns a
    triangle mesh into a vertical plane at 30 degrees (plane coordinates then round)."""
    rng = np.random.default_rng(seed)
    if kind == "tet":
        nodes, cells = box_tetrahedra(3, 2, 2, 1.0, 0.6, 0.6)
        nodes = perturb_interior(nodes, 0.04, seed=seed + 1)
    else:
        nodes, cells = rectangle_triangles(4, 3, 1.0, 0.6)
        nodes = perturb_interior(nodes, 0.04, seed=seed + 1)
    axes = 3 if kind == "tet" else 2
    pinned = np.flatnonzero(nodes[:, 0] == 0.0)
    positions, loads, velocities = nodes.copy(), np.zeros_like(nodes), np.zeros_like(nodes)
    positions[:, :axes] += 0.05 * rng.uniform(-1, 1, (len(nodes), axes))
    positions[pinned] = nodes[pinned]
    loads[:, :axes] = rng.uniform(-2, 2, (len(nodes), axes))
    velocities[:, :axes] = rng.uniform(-1, 1, (len(nodes), axes))
    velocities[pinned] = 0.0
    material = Material(1000.0, 0.3, 100.0, law)
    if kind == "tet":
        return TetMesh(nodes, cells, material, pinned=pinned, loads=loads,
                       positions=positions, velocities=velocities)
    if tilt:
        c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
        turn = np.array([[c, 0.0, 0.0], [s, 0.0, 0.0], [0.0, 1.0, 0.0]])
        nodes, positions, loads, velocities = (a @ turn.T for a in (nodes, positions, loads,
                                                                      velocities))
    return TriangleMesh(nodes, cells, material, thickness=0.1, plane=kind, pinned=pinned,
                        loads=loads, positions=positions, velocities=velocities)


@pytest.mark.parametrize("kind,tilt", [("stress", False), ("stress", True), ("strain", False),
                                       ("strain", True), ("tet", False)])
@pytest.mark.parametrize("name", LAW_NAMES)
def test_accel_equals_forces_over_masses(kind, name, tilt):
    mesh = mesh_of(kind, name, tilt)
    gravity = (0.0, -9.81, 0.0) if not tilt else (0.0, 0.0, -9.81)  # in the mesh's plane
    system = FemSystem(mesh, gravity, rayleigh=(0.3, 0.0))
    x, v = system.state()
    got = system.accel(0.0, x, v).reshape(-1, 3)
    want = system.forces(x, v) * system.inv_m  # the general route
    body = system.body
    local = body.to_local(system.full_positions(x))
    f = body.deformation_gradient(local)
    el = body.elements
    h = np.min(np.linalg.norm(el.dm, axis=1))
    sigma = 32 * stress_scale(body.law, f) * (1 + 4 * np.abs(local).max() / h)
    s_a = el.gather((el.volume[:, None] * np.abs(el.grad).sum(-1)) * sigma[:, None])
    valence = np.bincount(el.cells.reshape(-1)).max()
    terms = (valence + 3) * el.d * EPS * s_a[system.free] + 4 * EPS * (
        np.abs(system.external).max(1) + 0.3 * system.masses * np.abs(v.reshape(-1, 3)).max(1))
    bound = (terms / system.masses)[:, None]
    assert np.all(np.abs(got - want) <= bound), np.max(np.abs(got - want) / bound)
    assert np.abs(want).max() > 1e6 * bound.max()  # accelerations far above the bound


@pytest.mark.parametrize("formulation,rayleigh", [("as_printed", (0.0, 0.0)),
                                                  ("", (0.1, 0.01))])
def test_printed_forces_and_stiffness_damping_take_the_general_route(formulation, rayleigh):
    system = FemSystem(mesh_of("stress", "corotated"), rayleigh=rayleigh,
                       formulation=formulation)
    x, v = system.state()
    want = (system.forces(x, v) * system.inv_m).reshape(-1)
    assert np.array_equal(system.accel(0.0, x, v), want)  # the same operations
    assert system._maps is None  # the composed maps were never built


def test_stress_components_are_contiguous_runs():
    # the layout the fast path relies on: F and P entries one contiguous pass each
    law = make_law("corotated", 1.0, 0.3, 2)
    elements = irregular(2)
    f = elements.deformation_gradient(elements.rest * 1.01)
    p = law.stress(f)
    for a in (f, p):
        assert all(components(a)[i, j].flags.c_contiguous for i in range(2) for j in range(2))


def test_newton_polar_equals_the_svd_rotation_and_hands_inverted_elements_to_it():
    # F = R S with S positive definite: Newton's iteration converges to the SVD's U V^T to
    # round-off: R's condition number is 2 / (s2 + s3) (Higham 1986) on each side's rounding
    # of F, ~16 roundings of eps s1 per side (measured up to 38 eps s1 / (s2 + s3)); an
    # inverted element (det F < 0) is never iterated: the SVD's rotation-variant factor
    f = random_gradients(3, seed=11, spread=0.6)
    got, ok = newton_polar(np.moveaxis(f, 0, -1))
    u, s, vt = rotation_variant_svd(f)
    assert ok.all()
    diff = np.abs(np.moveaxis(got, -1, 0) - u @ vt).max(axis=(1, 2))
    assert np.all(diff <= 64 * EPS * s[:, 0] / (s[:, 1] + s[:, 2]))
    law = make_law("corotated", 1000.0, 0.3, 3)
    inverted = f[:5] * np.array([1.0, 1.0, -1.0])  # last column flipped: det < 0
    mixed = np.concatenate([f[5:10], inverted])
    assert np.array_equal(law.stress(mixed)[5:], matrix_stress(law, inverted))
