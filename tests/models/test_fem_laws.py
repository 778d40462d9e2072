"""The FEM laws against their closed forms: uniaxial stretch per law (nu = 0), forces as the
negative energy gradient, the stable Neo-Hookean's rest state and parameters
(refsim.models.fem.laws, fem_model)."""
import numpy as np
import pytest
from ulp import assert_ulp

from refsim.models.fem.laws import LAW_NAMES, make_law, neo_hookean_parameters
from refsim.models.fem.meshes import box_tetrahedra, perturb_interior, rectangle_triangles
from refsim.models.fem.model import ElasticBody
from refsim.scene import Material, TetMesh, TriangleMesh

E = 1.0e3
SETUPS = [(2, "stress"), (2, "strain"), (3, "stress")]


def body(d, plane, name, nu=0.0, jitter=0.0, size=(2, 2, 2)):
    material = Material(E, nu, 1.0, name)
    if d == 2:
        nodes, tris = rectangle_triangles(size[0], size[1], 2.0, 1.0)
        nodes = perturb_interior(nodes, jitter, seed=7)
        return ElasticBody.of(TriangleMesh(nodes, tris, material, thickness=0.1, plane=plane))
    nodes, tets = box_tetrahedra(*size, 2.0, 1.0, 1.0)
    return ElasticBody.of(TetMesh(perturb_interior(nodes, jitter, seed=8), tets, material))


def uniaxial(name, lam, law_dim):
    """(P11, P22) at F = diag(lambda, 1, ...) for nu = 0 (mu_L = E/2, lam_L = 0)."""
    if name in ("linear", "corotated"):
        return E * (lam - 1.0), 0.0
    if name == "green":
        return E * lam * (lam * lam - 1.0) / 2.0, 0.0
    # stable Neo-Hookean, d = law_dim: mu = (d+1)/d E/2, lam = (1 - 2/(d(d+1))) E/2,
    # alpha = 1 + d mu/((d+1) lam): d = 3 -> 2E/3, 5E/12, 11/5; d = 2 -> 3E/4, E/3, 5/2;
    # P = mu (1 - 1/(I_C + 1)) F + lam (J - alpha) cof F, I_C = lambda^2 + d - 1, J = lambda,
    # cof F = diag(1, lambda, ...)
    mu, la, alpha = ((2 * E / 3, 5 * E / 12, 2.2) if law_dim == 3 else (3 * E / 4, E / 3, 2.5))
    g = mu * (1.0 - 1.0 / (lam * lam + law_dim))
    return g * lam + la * (lam - alpha), g + la * (lam - alpha) * lam


@pytest.mark.parametrize("d,plane", SETUPS)
@pytest.mark.parametrize("name", LAW_NAMES)
@pytest.mark.parametrize("stretch", [0.8, 1.05, 1.5])
def test_uniaxial_stretch_with_nu_zero_gives_each_laws_closed_form(d, plane, name, stretch):
    b = body(d, plane, name)
    scale = np.ones(d)
    scale[0] = stretch
    x = b.elements.rest * scale
    p = b.stress(x)
    law_dim = 3 if (d == 3 or plane == "strain") else 2
    p11, p22 = uniaxial(name, stretch, law_dim)
    stress_scale = E * max(1.0, stretch) ** 3
    # F = diag(lambda, 1) to round-off, then a few operations (SVD, det, cofactor): 64 eps of
    # E lambda^3 (the largest term, StVK's)
    assert_ulp(p[:, 0, 0], np.full(len(p), p11), 64, "closed form vs the law's arithmetic",
               scale=stress_scale)
    assert_ulp(p[:, 1, 1], np.full(len(p), p22), 64, "closed form vs the law's arithmetic",
               scale=stress_scale)
    # the nodal forces on the face x = 2 add up to P11 times its area (1 x thickness, or 1)
    face = np.isclose(b.elements.rest[:, 0], 2.0)
    area = 0.1 if d == 2 else 1.0
    assert_ulp(b.forces(x)[face, 0].sum(), -p11 * area, 256, "element forces summed over "
               "the face's elements (a few dozen terms of E lambda^3 scale)",
               scale=stress_scale * area)


def test_neo_hookean_parameters_are_smith_et_als_reparametrisation():
    mu_l, lam_l = 3.0, 2.0
    mu, lam, alpha = neo_hookean_parameters(mu_l, lam_l, 3)
    assert (mu, lam, alpha) == pytest.approx((4.0, 2.0 + 2.5, 1.0 + 3 * 4.0 / (4 * 4.5)),
                                             rel=4e-16)  # a few roundings of each
    with pytest.raises(ValueError, match="poisson_ratio"):
        make_law("neo_hookean", E, -0.6, 2, "stress")  # plane stress lam <= 0


@pytest.mark.parametrize("d,plane", SETUPS)
def test_neo_hookean_rest_state_is_stress_free_and_linearises_to_linear_elasticity(d, plane):
    nh, lin = (make_law(n, E, 0.3, d, plane) for n in ("neo_hookean", "linear"))
    eye = np.eye(d)[None]
    assert np.abs(nh.stress(eye)).max() <= 8 * np.finfo(float).eps * E  # P(I) = 0
    assert abs(nh.energy_density(eye)[0]) <= 8 * np.finfo(float).eps * E  # Psi(I) removed
    assert_ulp(nh.tangent(eye), lin.tangent(eye), 16, "the reparametrisation makes the "
               "tangents equal at F = I; a few roundings of E", scale=E)


def central_gradient(energy, x, h):
    grad = np.zeros_like(x)
    for k in np.ndindex(x.shape):  # test oracle: one coordinate at a time
        e = np.zeros_like(x)
        e[k] = h
        grad[k] = (energy(x + e) - energy(x - e)) / (2 * h)
    return grad


@pytest.mark.parametrize("d,plane", SETUPS)
@pytest.mark.parametrize("name", LAW_NAMES)
def test_forces_are_the_negative_energy_gradient(d, plane, name):
    b = body(d, plane, name, nu=0.3, jitter=0.1)
    rng = np.random.default_rng(9)
    x = b.elements.rest + 0.1 * rng.standard_normal(b.elements.rest.shape)
    f = b.forces(x)
    grad = central_gradient(b.energy, x, 1e-6)
    # central differences: truncation h^2/6 U''' ~ (h / l)^2 |f| = 1e-11 |f| (element size
    # l ~ 0.5), round-off eps U / h ~ eps (l / h) |f| = 1e-10 |f|; the bound leaves 1000x
    # and is 10^4 below a 0.1 % error in the forces
    assert np.abs(f + grad).max() <= 1e-7 * np.abs(f).max()


def test_corotated_2d_closed_form_polar_is_the_rotation_variant_svd():
    """2D corotated takes R and the signed singular values in closed form; they are the
    rotation-variant SVD's (U V^T, s with the last carrying det F's sign), inverted elements
    included. Bounds: the SVD's backward error, taken as 8 eps |F| per entry (LAPACK's is a
    small multiple of eps |F|), for s; for R that error times the rotation's condition number
    2 / (s1 + s2) (a perturbation dF turns R by (dF - dF^T)_10 / tr S, Sifakis & Barbic)."""
    from refsim.models.fem.laws import Corotated, rotation_variant_svd
    rng = np.random.default_rng(11)
    f = np.eye(2) + 0.6 * rng.standard_normal((400, 2, 2))
    f[:40, :, 0] *= -1.0  # inverted elements (det F < 0)
    assert (np.linalg.det(f) < 0).sum() >= 40
    rot, s, vt = Corotated(1.0, 1.0, 2)._polar(f)
    u, s_svd, vt_svd = rotation_variant_svd(f)
    scale = np.abs(f).max(axis=(1, 2))
    assert vt is None
    error = 8 * 2.2e-16 * scale
    assert np.all(np.abs(rot - u @ vt_svd).max(axis=(1, 2)) <= error * 2.0 / s_svd.sum(-1))
    assert np.all(np.abs(s - s_svd).max(-1) <= 8 * 2.2e-16 * scale)
    assert np.allclose(np.linalg.det(rot), 1.0, rtol=0, atol=4 * 2.2e-16)
