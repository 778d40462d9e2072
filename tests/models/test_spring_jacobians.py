"""Issue 16, first step: spring-network Jacobians assembled as scipy.sparse equal the dense
ones, and Baraff-Witkin's sparse solve equals the dense solve (direct: to round-off; CG: to
its stated tolerance) and, on a linear string, is exactly backward Euler on every mode."""
import numpy as np
import pytest

from refsim_cases.grid_evolution.wave_mode import step_matrix
from refsim.integrators.implicit import SPARSE_MIN, BaraffWitkin, implicit_matrix, matvec, solve
from refsim.models.forces import SpringSet
from refsim.models.spring_jacobians import sparse_jacobians
from refsim.models.system import ParticleSystem

EPS = np.finfo(float).eps


def _random_network(seed, n=9, m=20):
    rng = np.random.default_rng(seed)
    body = rng.integers(0, n, m)
    other = rng.integers(-1, n, m)
    other[other == body] = -1  # some anchors, some shared ends
    springs = SpringSet(body=body, other=other, anchor=rng.standard_normal((m, 3)),
                        stiffness=rng.uniform(1, 5, m), rest=rng.uniform(0.1, 1, m),
                        damping=rng.uniform(0, 1, m))
    return springs, rng.standard_normal((n, 3)), rng.standard_normal((n, 3))


@pytest.mark.parametrize("seed", range(5))
def test_sparse_jacobians_equal_the_dense_ones(seed):
    springs, x, v = _random_network(seed)
    jx, jv = springs.jacobians(x, v)
    sx, sv = sparse_jacobians(springs, x, v)
    # the same block sums in another order: a few eps of the largest block sum
    scale = 4 * np.max(springs.stiffness) * (1 + np.max(springs.rest) / 0.01)
    assert np.max(np.abs(jx - sx.toarray())) <= 8 * EPS * scale
    assert np.max(np.abs(jv - sv.toarray())) <= 8 * EPS * 4 * np.max(springs.damping)


def _chain(n, rest, damping, drag=0.0, gravity=(0.0, 0.0, -9.81)):
    """n nodes, springs to the previous node, the first and last also to anchors."""
    body = np.r_[np.arange(n), n - 1]
    other = np.r_[-1, np.arange(n - 1), -1]
    anchor = np.zeros((n + 1, 3))
    anchor[-1] = [(n + 1) * 0.1, 0.0, 0.0]
    springs = SpringSet(body=body, other=other, anchor=anchor, stiffness=np.full(n + 1, 1e3),
                        rest=np.full(n + 1, rest), damping=np.full(n + 1, damping))
    masses = np.full(n, 0.01)
    return ParticleSystem(masses, gravity, drag=drag, springs=springs)


@pytest.mark.parametrize("solver,bound", [("direct", 64 * EPS), ("cg", 1e-9)])
def test_sparse_baraff_witkin_step_equals_the_dense_solve(solver, bound):
    """Direct: the same linear system solved two ways (backward-stable, condition number of
    M - h D - h^2 K times eps, ~50 here). CG: stopped at rtol 1e-10 of the right-hand side."""
    n = 40  # state 120 >= SPARSE_MIN: the sparse path
    assert 3 * n >= SPARSE_MIN
    system = _chain(n, rest=0.09, damping=0.5, drag=0.1)
    rng = np.random.default_rng(3)
    x = np.c_[np.arange(1, n + 1) * 0.1, np.zeros(n), np.zeros(n)].ravel()
    x = x + 0.01 * rng.standard_normal(3 * n)
    v = 0.1 * rng.standard_normal(3 * n)
    h = 0.01
    jac, ax = implicit_matrix(system, 0.0, x, v, h)
    dense_v = v + solve(jac, h * (system.accel(0.0, x, v) + h * matvec(ax, v)))
    x1, v1 = BaraffWitkin(solver).step(system, 0.0, (x, v), h)
    assert np.max(np.abs(v1 - dense_v)) <= bound * np.max(np.abs(dense_v))
    # same operations: the stepper's drift x + h v1, numpy ufuncs
    assert np.array_equal(x1, x + h * v1)


@pytest.mark.parametrize("mode", [1, 3])
def test_baraff_witkin_on_a_linear_string_is_backward_euler_on_each_mode(mode):
    """Zero-rest-length springs (k = 1e3 N/m, m = 0.01 kg) between n = 200 nodes and two
    anchors: linear forces, so Baraff-Witkin is backward Euler, and the transverse mode
    sin(p pi j / (n + 1)) of w^2 = (4 k / m) sin^2(p pi / (2 (n + 1))) evolves by the 2x2
    step [[1, -h], [h w^2, 1]]^-1: its amplitude factor per step is (1 + w^2 h^2)^(-1/2),
    here at w h = 2.1 (far past the explicit limit 2 on the stiffest mode)."""
    n, k, m = 200, 1e3, 0.01
    system = _chain(n, rest=0.0, damping=0.0, gravity=(0.0, 0.0, 0.0))
    j = np.arange(1, n + 1)
    shape = np.sin(mode * np.pi * j / (n + 1))
    x0 = np.c_[j * 0.1, np.zeros(n), 0.01 * shape].ravel()  # the line x_j = 0.1 j is at rest
    w = np.sqrt(4 * k / m) * np.sin(mode * np.pi / (2 * (n + 1)))
    h = 2.1 * np.sqrt(m / (4 * k))
    steps = 25
    state = (x0, np.zeros(3 * n))
    stepper = BaraffWitkin("direct")
    for _ in range(steps):
        state = stepper.step(system, 0.0, state, h)
    factor = np.linalg.matrix_power(step_matrix("implicit_euler", w, h), steps)[0, 0]
    z = state[0].reshape(n, 3)[:, 2]
    # each step rounds by a few eps of the 0.01 m amplitude, not amplified (|factor| <= 1)
    assert np.max(np.abs(z - factor * 0.01 * shape)) <= steps * 64 * EPS * 0.01
    assert abs(factor) < 1.0  # numerical damping, measured: the exact (1 + w^2 h^2)^(-k/2)


@pytest.mark.parametrize("seed", range(3))
def test_the_assembler_with_a_fixed_pattern_equals_the_one_off_assembly(seed):
    from refsim.models.spring_jacobians import JacobianAssembler
    springs, x, v = _random_network(seed, n=30, m=80)
    assembler = JacobianAssembler(springs, 30)
    for _ in range(2):  # the pattern is reused
        ax, av = assembler(x, v)
        sx, sv = sparse_jacobians(springs, x, v)
        # the same sums; bincount adds in triplet order, scipy in its own
        assert np.max(np.abs((ax - sx).toarray())) <= 16 * EPS * np.max(np.abs(sx.toarray()))
        assert np.max(np.abs((av - sv).toarray())) <= 16 * EPS * np.max(np.abs(sv.toarray()))
        x = x + 0.1
