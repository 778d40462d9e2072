"""Hinge and dihedral bending terms (refsim.models.bending): forces are -grad energy, Jacobians
are d forces / dx (both against central differences with a Richardson-estimated truncation
bound), symmetric, continuous through the straight hinge, the straight chain's exact
linearised stiffness, and a hinge network driven to its static equilibrium by Baraff-Witkin."""
import numpy as np
import pytest
from scipy.optimize import brentq

from refsim.integrators.implicit import SPARSE_MIN, BaraffWitkin
from refsim.models.bending import DihedralSet, HingeSet, _sin_minus_t_cos_over_t3
from refsim.models.spring_network import NetworkSystem
from refsim.scene.networks import SpringNetwork

EPS = np.finfo(float).eps
H = 1e-4  # central-difference step (m), lengths here are O(1) m


def _hinges(seed, n=7):
    rng = np.random.default_rng(seed)
    nodes = np.array([[0, 1, 2], [1, 2, 3], [2, 3, 4], [4, 5, 6], [1, 3, 5]])
    term = HingeSet(nodes, rng.uniform(1, 3, len(nodes)), rng.uniform(0, 2.5, len(nodes)), n)
    return term, rng.standard_normal((n, 3))


def _dihedrals(seed, n=6):
    rng = np.random.default_rng(seed)
    nodes = np.array([[0, 1, 2, 3], [1, 2, 3, 4], [2, 4, 3, 5]])
    term = DihedralSet(nodes, rng.uniform(1, 3, len(nodes)), rng.uniform(-2.5, 2.5, len(nodes)),
                       n)
    return term, rng.standard_normal((n, 3))


def _central(fun, x, h):
    """d fun / dx by central differences of step h: (out_shape..., n, 3)."""
    cols = []
    for index in np.ndindex(x.shape):
        step = np.zeros_like(x)
        step[index] = h
        cols.append((np.asarray(fun(x + step)) - np.asarray(fun(x - step))) / (2 * h))
    return np.moveaxis(np.array(cols), 0, -1).reshape(np.shape(cols[0]) + x.shape)


def _check_derivative(exact, fun, x, value_scale):
    """Central differences D(h) = d + a h^2 + O(h^4): the truncation of D(h/2) is
    (D(h) - D(h/2)) / 3 to O(h^4) (Richardson); allowed twice that, plus the round-off of the
    quotient, 8 eps |fun| / (h / 2)."""
    coarse, fine = _central(fun, x, H), _central(fun, x, H / 2)
    bound = 2 * np.abs(coarse - fine) / 3 + 8 * EPS * value_scale / (H / 2)
    assert np.all(np.abs(exact - fine) <= bound)


def _term_scale(term, x):
    return np.sum(term.k * ((np.abs(term.angles(x) - term.theta0) + 1) ** 2))


@pytest.mark.parametrize("make", [_hinges, _dihedrals])
@pytest.mark.parametrize("seed", range(3))
def test_forces_are_minus_the_energy_gradient(make, seed):
    term, x = make(seed)
    _check_derivative(-term.forces(x), term.energy, x, _term_scale(term, x))


@pytest.mark.parametrize("make", [_hinges, _dihedrals])
@pytest.mark.parametrize("seed", range(3))
def test_jacobian_is_the_force_derivative_and_symmetric(make, seed):
    term, x = make(seed)
    jac = term.jacobian(x).toarray()
    n = len(x)
    exact = jac.reshape(n, 3, n, 3)
    _check_derivative(exact, term.forces, x, _term_scale(term, x))
    # each entry is the same sum of block terms in two summation orders: a few eps of the
    # largest entry per term (at most 5 terms share a node pair here)
    assert np.max(np.abs(jac - jac.T)) <= 5 * 4 * EPS * np.max(np.abs(jac))


@pytest.mark.parametrize("make", [_hinges, _dihedrals])
def test_forces_take_batch_axes(make):
    term, x = make(0)
    batch = np.stack([x, 1.1 * x, x + 0.2])
    forces = term.forces(batch.reshape(3, 1, -1, 3))
    for b in range(3):
        # same operations per instance: elementwise ufuncs, reductions over the same last axes
        assert np.array_equal(forces[b, 0], term.forces(batch[b]))


def test_series_and_direct_quotient_agree_at_the_switch():
    """(sin t - t cos t) / t^3 by its series (|t| <= 1) and directly (|t| > 1) at t = 1:
    the direct form's cancellation costs ~ eps / t^2 relative, 1e-15 at t = 1."""
    t = np.array([1.0, np.nextafter(1.0, 2)])
    direct = (np.sin(t) - t * np.cos(t)) / t ** 3
    assert np.allclose(_sin_minus_t_cos_over_t3(t), direct, rtol=8 * EPS, atol=0)
    # exact: the series at t = 0 is its constant 1/3 plus products with t^2 = 0
    assert _sin_minus_t_cos_over_t3(np.array([0.0]))[0] == 1 / 3


def _straight_hinge():
    x = np.array([[0.0, 0, 0], [1.0, 0, 0], [2.5, 0, 0]])
    return HingeSet(np.array([[0, 1, 2]]), np.array([2.0]), np.array([0.0]), 3), x


def test_straight_hinge_is_smooth():
    """theta0 = 0 at theta = 0: force exactly 0, the Jacobian equal to the central difference of
    the forces there (bounds as above), and forces/Jacobians Lipschitz through theta = 0: a
    bend of s (m) moves them by <= C s with C the Jacobian's own size / length scale."""
    term, x = _straight_hinge()
    # exact zeros: collinear nodes, theta = theta0 = 0: every force term is a product with 0
    assert np.all(term.forces(x) == 0)
    jac0 = term.jacobian(x).toarray()
    _check_derivative(jac0.reshape(3, 3, 3, 3), term.forces, x, 2.0)
    lipschitz = 4 * np.max(np.abs(jac0)) / 1.0  # shortest link 1 m
    for s in (-1e-6, -1e-12, 1e-12, 1e-6, 1e-3):
        bent = x.copy()
        bent[2, 2] = s
        assert np.max(np.abs(term.jacobian(bent).toarray() - jac0)) <= lipschitz * abs(s)
        assert np.max(np.abs(term.forces(bent))) <= np.max(np.abs(jac0)) * abs(s) * 1.01


def test_rest_angle_cone_raises_nothing():
    """theta0 != 0 at theta = 0: the cone's tip, force 0 and finite Jacobian (module doc)."""
    term, x = _straight_hinge()
    cone = HingeSet(term.nodes, term.k, np.array([0.3]), 3)
    # exact zeros: the cone's tip returns force 0 by construction
    assert np.all(cone.forces(x) == 0)
    assert np.all(np.isfinite(cone.jacobian(x).toarray()))


def test_straight_chain_linearised_stiffness():
    """Straight chain along x with links l_i: near straight, theta_b = |(w_c - w_b)/l2 -
    (w_b - w_a)/l1| in each transverse direction w, so Hess E = k v v^T, v = (1/l1,
    -(1/l1 + 1/l2), 1/l2), on y and on z; nothing on x or across. Exact at theta = 0 (the
    Hessian of the smooth 1/2 k theta^2 is its quadratic form), to round-off."""
    lengths = np.array([1.0, 0.5, 2.0, 1.5, 1.0])
    n = len(lengths) + 1
    x = np.zeros((n, 3))
    x[1:, 0] = np.cumsum(lengths)
    k = np.array([1.0, 2.0, 3.0, 4.0])
    term = HingeSet(np.c_[np.arange(n - 2), np.arange(1, n - 1), np.arange(2, n)], k,
                    np.zeros(n - 2), n)
    jac = term.jacobian(x).toarray().reshape(n, 3, n, 3)
    stencil = np.zeros((n - 2, n))
    for h in range(n - 2):  # the test's own second-difference rows
        stencil[h, h:h + 3] = 1 / lengths[h], -(1 / lengths[h] + 1 / lengths[h + 1]), \
            1 / lengths[h + 1]
    expected = -stencil.T @ np.diag(k) @ stencil
    scale = np.max(np.abs(expected))
    for axis in (1, 2):
        assert np.max(np.abs(jac[:, axis, :, axis] - expected)) <= 16 * EPS * scale
    others = jac.copy()
    others[:, 1, :, 1] = others[:, 2, :, 2] = 0
    assert np.max(np.abs(others)) <= 16 * EPS * scale


def _hair(n_links, link, k_stretch, k_bend, masses):
    x = np.zeros((n_links + 2, 3))
    x[:, 0] = np.arange(-1, n_links + 1) * link
    n = len(x)
    return SpringNetwork(positions=x, masses=masses, edges=np.c_[np.arange(n - 1),
                                                                  np.arange(1, n)],
                         stiffness=k_stretch, hinges=np.c_[np.arange(n - 2),
                                                           np.arange(1, n - 1),
                                                           np.arange(2, n)],
                         hinge_stiffness=k_bend, hinge_rest_angle=0.0, pinned=[0, 1])


def _newton_like_bw(system, x, v, h=1e4, steps=40):
    """Baraff-Witkin at h -> inf is Newton's method on the statics (see the hair case)."""
    stepper, state = BaraffWitkin(), (x, v)
    for k in range(steps):
        state = stepper.step(system, k * h, state, h)
    return state


def test_single_hinge_equilibrium_by_baraff_witkin():
    """One free node on one link below a clamped root: moment balance k_b phi = m g L cos phi,
    the link stretched to L = l (1 + m g sin phi / k_s) (its tension is the weight's component
    along it), solved by brentq to 1e-15; Baraff-Witkin at large h reaches it to round-off
    (8 eps of the positions; the Newton iteration converges quadratically)."""
    link, k_s, k_b, m, g = 1.0, 1e4, 5.0, 0.3, 9.81
    net = _hair(1, link, k_s, k_b, [1.0, 1.0, m])
    system = NetworkSystem(net, (0, 0, -g), drag=0.1)

    def moment(phi):
        length = link * (1 + m * g * np.sin(phi) / k_s)
        return k_b * phi - m * g * length * np.cos(phi)

    phi = brentq(moment, 0, np.pi / 2, xtol=1e-15, rtol=4 * EPS)
    length = link * (1 + m * g * np.sin(phi) / k_s)
    expected = np.array([length * np.cos(phi), 0, -length * np.sin(phi)])
    x, _ = _newton_like_bw(system, net.positions[2].copy(), np.zeros(3))
    assert np.max(np.abs(x - expected)) <= 8 * EPS * 2 * link


def test_long_hair_sparse_baraff_witkin_reaches_zero_force():
    """40 free nodes (state 120 >= SPARSE_MIN: the sparse solve with the bending Jacobian):
    Baraff-Witkin at large h leaves a net force at the round-off of the stiffest term: the
    node positions (|x| <= L) are known to eps |x|, which the stretch springs turn into
    k_s eps L of force (a few such terms per node: 8 k_s eps L)."""
    n_links, link, k_s, m, g = 40, 0.05, 1e4, 0.01, 9.81
    net = _hair(n_links, link, k_s, 0.05, m)
    system = NetworkSystem(net, (0, 0, -g), drag=0.0)
    assert 3 * system.nbody >= SPARSE_MIN
    x0 = net.positions[2:].reshape(-1)
    x, _ = _newton_like_bw(system, x0, np.zeros_like(x0))
    force = system.forces(x, np.zeros_like(x)) + system.masses[:, None] * np.array([0, 0, -g])
    assert np.max(np.abs(force)) <= 8 * k_s * EPS * n_links * link
    assert np.max(np.abs(x - x0)) > 0.1  # it did bend (the tip drops by a large part of L)
