"""Static Newton equilibria against closed forms (refsim.models.fem.static): uniaxial stretch
per law, and the Timoshenko cantilever's tip deflection and convergence orders on P1."""
import numpy as np
import pytest
from scipy.optimize import brentq

from refsim.models.fem.cantilever import Cantilever, error_norms, triangle_rule
from refsim.models.fem.meshes import rectangle_triangles
from refsim.models.fem.model import ElasticBody
from refsim.models.fem.static import StaticFailure, solve_static
from refsim.scene import Material, TriangleMesh

E, THICK, FORCE = 1000.0, 0.1, 10.0


def stretched_square(name, nx=1, ny=1):
    """A 1 x 1 square (thickness 0.1, nu = 0), x held on x = 0 and y at the origin; FORCE in
    +x on x = 1 as consistent nodal loads (edge lengths / 2 per node)."""
    nodes, tris = rectangle_triangles(nx, ny)
    b = ElasticBody.of(TriangleMesh(nodes, tris, Material(E, 0.0, 1.0, name),
                                    thickness=THICK))
    fixed = np.zeros((len(nodes), 2), bool)
    fixed[nodes[:, 0] == 0, 0] = True
    fixed[0, 1] = True
    loads = np.zeros((len(nodes), 2))
    edge = nodes[:, 0] == 1
    loads[edge, 0] = FORCE / ny
    loads[edge & ((nodes[:, 1] == 0) | (nodes[:, 1] == 1)), 0] = FORCE / ny / 2
    return b, fixed, loads


@pytest.mark.parametrize("name,root", [
    ("linear", lambda s: 1 + s / E),
    ("corotated", lambda s: 1 + s / E),
    # MuJoCo 4's flex probe on the same square settled at 1.088034
    ("green", lambda s: brentq(lambda lam: E * lam * (lam * lam - 1) / 2 - s, 1.0, 2.0,
                               xtol=1e-15))])
@pytest.mark.parametrize("mesh", [(1, 1), (3, 2)])
def test_a_stretched_square_settles_at_the_laws_uniaxial_stretch(name, root, mesh):
    b, fixed, loads = stretched_square(name, *mesh)
    result = solve_static(b, loads, fixed)
    stretch = root(FORCE / THICK)  # P11 = F / (t x 1)
    f = b.deformation_gradient(result.x)
    # Newton stops at rtol 1e-10 of the force scale (stiffness E t: a position error of
    # 1e-10 F / (E t) = 1e-11) or at the positions' round-off: 1e-12 leaves 10x
    assert np.abs(f - np.diag([stretch, 1.0])).max() <= 1e-12
    if name == "green":
        assert abs(stretch - 1.088034) < 5e-7  # the MuJoCo probe's 7 digits
        assert result.iterations >= 3  # nonlinear: Newton iterates


def test_neo_hookean_stretch_contracts_laterally_to_its_two_equation_root():
    # stable Neo-Hookean, plane stress, nu_L = 0: mu = 3E/4, lam = E/3, alpha = 5/2 (d = 2);
    # F = diag(a, b) with P22 = 0 (free lateral faces) and P11 = F / t:
    # P11 = mu g a + lam (ab - alpha) b, P22 = mu g b + lam (ab - alpha) a,
    # g = 1 - 1/(a^2 + b^2 + 1)
    b_, fixed, loads = stretched_square("neo_hookean", 2, 2)
    result = solve_static(b_, loads, fixed)
    mu, lam, alpha = 0.75 * E, E / 3, 2.5

    def p22_zero(a):  # the lateral stretch b(a) with P22 = 0
        return brentq(lambda b: mu * (1 - 1 / (a * a + b * b + 1)) * b
                      + lam * (a * b - alpha) * a, 0.5, 2.0, xtol=1e-15)

    def p11(a):
        b = p22_zero(a)
        return mu * (1 - 1 / (a * a + b * b + 1)) * a + lam * (a * b - alpha) * b

    a = brentq(lambda a: p11(a) - FORCE / THICK, 1.0, 2.0, xtol=1e-15)
    f = b_.deformation_gradient(result.x)
    assert np.abs(f - np.diag([a, p22_zero(a)])).max() <= 1e-12  # as above
    assert p22_zero(a) < 1.0 - 1e-3  # it contracts, where StVK with nu = 0 does not


def test_newton_that_cannot_converge_says_so():
    b, fixed, loads = stretched_square("green")
    with pytest.raises(StaticFailure, match="residual"):
        solve_static(b, 1e4 * loads, fixed, max_iter=2)


def test_the_triangle_rule_integrates_degree_eight_exactly():
    points, weights = triangle_rule(5)
    x, y = points.T
    # int over the unit right triangle of x^a y^b = a! b! / (a + b + 2)!
    assert abs(weights @ (x ** 5 * y ** 3) - 120 * 6 / 3628800) < 1e-18  # 1/5040: exact
    # to round-off (25 terms of ~1e-4)


def cantilever_solution(k):
    beam = Cantilever()
    nodes, tris = beam.mesh(4 * k, k)
    b = ElasticBody.of(TriangleMesh(nodes, tris, Material(3e7, 0.3, 1.0, "linear")))
    fixed, x0, loads = beam.boundary(nodes)
    x = solve_static(b, loads, fixed, x0).x
    tip = np.flatnonzero((nodes[:, 0] == 48) & (nodes[:, 1] == 0))[0]
    return beam, b, x, x[tip, 1] - nodes[tip, 1], 48.0 / (4 * k)


def test_timoshenko_tip_deflection_is_its_closed_form():
    beam = Cantilever()
    assert abs(beam.tip_deflection() - 0.0089) < 1e-17  # 0.0089000 (the closed form's digits)
    i = 12.0 ** 3 / 12
    assert beam.tip_deflection() == pytest.approx(
        1000 * 48 ** 3 / (3 * 3e7 * i) + 5.5 * 1000 * 144 * 48 / (24 * 3e7 * i), rel=1e-15)


def test_timoshenko_cantilever_converges_to_its_exact_field_at_the_p1_orders():
    runs = [cantilever_solution(k) for k in (8, 16, 32)]  # nx = 32..128 cells along L
    h = np.array([r[4] for r in runs])
    norms = np.array([error_norms(r[0], r[1], r[2]) for r in runs])
    l2_order = np.polyfit(np.log(h), np.log(norms[:, 0]), 1)[0]
    energy_order = np.polyfit(np.log(h), np.log(norms[:, 1]), 1)[0]
    # measured 1.962 and 0.982 (fit over h = 1.5, 0.75, 0.375); the pre-asymptotic terms are
    # one order higher, so the fitted slopes approach 2 and 1 from below as h halves
    # (1.79 -> 1.94 -> 1.98 pairwise in L2): +-0.1 and +-0.05
    assert abs(l2_order - 2.0) <= 0.1
    assert abs(energy_order - 1.0) <= 0.05
    # the tip deflection converges as O(h^2) to 0.0089000: its error on the finest mesh
    # equals Richardson's estimate (v_h - v_2h) / 3 within 5 % (measured 1.5 %; a 0.1 %
    # error in the closed form moves the ratio by 30 %)
    v_coarse, v_fine = runs[1][3], runs[2][3]
    estimate = (v_fine - v_coarse) / 3.0
    assert abs((0.0089 - v_fine) / estimate - 1.0) <= 0.05
    assert 0.0089 - v_fine > 0  # P1 is too stiff in bending: it undershoots
