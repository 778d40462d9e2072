"""The FEM mesh as a system for the steppers (refsim.models.fem.system): accelerations and
Jacobians consistent with the energy, velocity Verlet's energy within its modal bound,
implicit Euler and Baraff-Witkin (sparse path) on their exact discrete energy decay."""
import numpy as np
import pytest
import scipy.linalg as sl
from ulp import assert_ulp

from refsim.integrators import get_integrator
from refsim.integrators.implicit import SPARSE_MIN
from refsim.models.fem.meshes import box_tetrahedra, rectangle_triangles
from refsim.models.fem.system import FemSystem
from refsim.scene import Material, TetMesh, TriangleMesh


def beam(name, nx=4, ny=2, **kw):
    """A 1 x 0.25 x 0.01 plate clamped on x = 0, swung by v_y = 0.2 x (E = 1e4, rho = 1000)."""
    nodes, tris = rectangle_triangles(nx, ny, 1.0, 0.25)
    velocities = np.zeros_like(nodes)
    velocities[:, 1] = 0.2 * nodes[:, 0]
    mesh = TriangleMesh(nodes, tris, Material(1e4, 0.3, 1000.0, name), velocities=velocities,
                        thickness=0.01, pinned=np.flatnonzero(nodes[:, 0] == 0))
    return FemSystem(mesh, **kw)


def modes(system):
    """(omega^2, modal energies) of the linearised system at rest for its initial velocity
    (in-plane dofs: the out-of-plane ones carry no stiffness and no velocity)."""
    x, v = system.state()
    k = -system.sparse_force_jacobians(0.0, x, v)[0].toarray()
    m = np.repeat(system.masses, 3)
    keep = np.abs(k).sum(1) > 0
    w2, phi = sl.eigh(k[np.ix_(keep, keep)], np.diag(m[keep]))
    return w2, 0.5 * (phi.T @ (m[keep] * v[keep])) ** 2


def energy(system, x, v):
    return system.kinetic_energy(v) + system.potential_energy(x)


def test_forces_are_minus_the_potential_gradient_and_jacobians_their_derivative():
    nodes, tets = box_tetrahedra(2, 1, 1, 2.0, 1.0, 1.0)
    loads = np.zeros_like(nodes)
    loads[-1] = [0.0, 0.0, -3.0]
    mesh = TetMesh(nodes, tets, Material(1e3, 0.3, 500.0, "neo_hookean"), pinned=[0, 3],
                   loads=loads)
    system = FemSystem(mesh, gravity=(0.0, 0.0, -9.81))
    rng = np.random.default_rng(21)
    x = system.state()[0] + 0.05 * rng.standard_normal(3 * system.nbody)
    v = np.zeros_like(x)
    f = system.forces(x, v).reshape(-1)
    h = 1e-6
    grad = np.array([(system.potential_energy(x + h * e) - system.potential_energy(x - h * e))
                     / (2 * h) for e in np.eye(len(x))])  # test oracle, one dof at a time
    # central differences: truncation (h / l)^2 ~ 1e-12, round-off eps U / h ~ 1e-10 of |f|
    assert np.abs(f + grad).max() <= 1e-7 * np.abs(f).max()
    ax, av = system.jacobians(0.0, x, v)
    fd = np.array([(system.accel(0, x + h * e, v) - system.accel(0, x - h * e, v)) / (2 * h)
                   for e in np.eye(len(x))]).T
    assert np.abs(ax - fd).max() <= 1e-7 * np.abs(ax).max()  # the same bound
    assert not av.any() and not system.velocity_dependent


def test_a_triangle_mesh_moves_in_its_plane_and_refuses_gravity_across_it():
    system = beam("corotated", gravity=(0.0, -9.81, 0.0))
    x, v = system.state()
    a = system.accel(0.0, x, v).reshape(-1, 3)
    assert not a[:, 2].any() and a[:, 1].min() < 0
    with pytest.raises(ValueError, match="gravity must lie"):
        beam("corotated", gravity=(0.0, 0.0, -9.81))
    with pytest.raises(ValueError, match="no batch"):
        system.accel(0.0, np.stack([x, x]), np.stack([v, v]))


@pytest.mark.parametrize("name,slack", [("linear", 1.0), ("corotated", 1.05)])
def test_velocity_verlet_keeps_the_energy_within_its_modal_bound(name, slack):
    # velocity Verlet on x'' = -w^2 x conserves v^2 + w^2 (1 - (h w)^2 / 4) x^2, so a mode's
    # energy oscillates by at most E_k (h w_k)^2 / (4 - (h w_k)^2); the linear law's modes are
    # exactly these, summed. The corotated law at these strains (1 %) is linear to ~1 %: 5 %
    system = beam(name)
    w2, e_k = modes(system)
    x, v = system.state()
    e0 = energy(system, x, v)
    worst = []
    for h in 0.5 / np.sqrt(w2.max()) * np.array([1.0, 0.5]):
        stepper = get_integrator("velocity_verlet")
        state, t, errors = stepper.start(system, 0.0, x, v, h), 0.0, []
        # half the slowest period: a mode's energy error oscillates at twice its frequency
        for _ in range(int(np.pi / np.sqrt(w2.min()) / h)):
            t, state = stepper.advance(system, t, state, h, 1)
            errors.append(abs(energy(system, *stepper.output(system, t, state, h)) - e0))
        bound = np.sum(e_k * h * h * w2 / (4 - h * h * w2))
        assert max(errors) <= slack * bound
        assert max(errors) >= 0.5 * bound  # the bound is what it measures, not a ceiling
        worst.append(max(errors))
    assert 3.8 <= worst[0] / worst[1] <= 4.2  # second order in h


@pytest.mark.parametrize("integrator,size", [("implicit_euler", (4, 2)),
                                             ("baraff_witkin", (8, 4))])
def test_implicit_steppers_decay_each_mode_by_the_exact_discrete_factor(integrator, size):
    # backward Euler on x'' = -w^2 x is (w x, v)_1 = (I + h w J)^-1 (w x, v)_0, J a quarter
    # turn: each mode's energy shrinks by exactly 1 / (1 + h^2 w^2) a step. The linear law
    # is linear, so E_n = sum_k E_k (1 + h^2 w_k^2)^-n; Baraff-Witkin is one Newton step of
    # backward Euler, exact on a linear system (run at 8 x 4 cells: its sparse path)
    system = beam("linear", *size)
    x, v = system.state()
    assert (len(x) >= SPARSE_MIN) == (integrator == "baraff_witkin")
    w2, e_k = modes(system)
    h, n = 0.05, 40  # h w = 0.06 on the slowest mode, 3 on the fastest
    stepper = get_integrator(integrator)
    t, state = stepper.advance(system, 0.0, stepper.start(system, 0.0, x, v, h), h, n)
    got = energy(system, *stepper.output(system, t, state, h))
    want = np.sum(e_k * (1 + h * h * w2) ** -n)
    assert want < 0.9 * np.sum(e_k)  # the decay is there to measure
    assert_ulp(got, want, 2e3, "strains from positions carry eps |x| / |u| ~ 50 eps (0.02 m "
               "displacements of 1 m coordinates), 40 solves of condition 1 + (h w_max)^2 <= 38 "
               "add a few eps each; measured 160", scale=np.sum(e_k))


def test_the_sparse_and_dense_jacobians_agree_and_rayleigh_damping_enters_both():
    system = beam("corotated", rayleigh=(0.5, 1e-3))
    x, v = system.state()
    x = x + 0.01 * np.random.default_rng(22).standard_normal(len(x))
    kx, kv = system.sparse_force_jacobians(0.0, x, v)
    ax, av = system.jacobians(0.0, x, v)
    inv_m = np.repeat(1 / system.masses, 3)[:, None]
    assert np.array_equal(ax, inv_m * kx.toarray())  # the same product, elementwise
    assert_ulp(kv.toarray(), -0.5 * np.diag(np.repeat(system.masses, 3)) + 1e-3 * kx.toarray(),
               4, "alpha M + beta K summed as sparse matrices", scale=np.abs(kv).max())
    assert system.velocity_dependent and np.abs(av).max() > 0
    f_damped = system.forces(x, v)
    f_free = beam("corotated").forces(x, v)
    assert_ulp(f_damped.reshape(-1), f_free.reshape(-1) + kv @ v, 64, "the damping force is "
               "df/dv v (linear in v); sparse products in another order",
               scale=np.abs(f_free).max())
