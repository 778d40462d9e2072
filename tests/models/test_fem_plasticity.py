"""Von Mises plasticity on the FEM strain measures (refsim.models.fem.plasticity): the permanent
strain of a uniaxial stretch past yield and unload against its closed form, and the energy
balance of a yielding bar stepped in time (plastic strain stored per element)."""
import numpy as np
import pytest

from refsim.integrators import get_integrator
from refsim.models.fem.meshes import box_tetrahedra, rectangle_triangles
from refsim.models.fem.model import ElasticBody
from refsim.models.fem.static import solve_static
from refsim.models.fem.system import FemSystem
from refsim.scene import Material, Plasticity, TetMesh, TriangleMesh

E, NU, YIELD = 1000.0, 0.3, 10.0  # yield strain 0.01


def measure(name, f11):
    """The law's axial strain of an axial stretch: Green's (lambda^2 - 1)/2, else lambda - 1."""
    return (f11 * f11 - 1.0) / 2.0 if name == "green" else f11 - 1.0


def unit_cube(name, hardening):
    nodes, tets = box_tetrahedra(2, 2, 2)
    b = ElasticBody.of(TetMesh(nodes, tets, Material(E, NU, 1.0, name,
                                                     Plasticity(YIELD, hardening))))
    rest = b.elements.rest
    fixed = np.zeros_like(rest, bool)  # x held on x = 0; rigid motions removed, lateral free
    fixed[rest[:, 0] == 0, 0] = True
    fixed[np.all(rest == 0, 1), :] = True
    fixed[np.all(rest == [0.0, 1.0, 0.0], 1), 2] = True
    return b, fixed


@pytest.mark.parametrize("name", ["linear", "green", "corotated"])
@pytest.mark.parametrize("hardening", [0.0, 200.0])
def test_a_stretch_past_yield_and_release_leaves_the_closed_form_permanent_strain(name,
                                                                                   hardening):
    b, fixed = unit_cube(name, hardening)
    rest = b.elements.rest
    right = rest[:, 0] == 1
    stretch = 1.03
    x0 = rest.copy()
    x0[right, 0] = stretch  # the x = 1 face pulled to 1.03 (3x the yield strain)
    loaded = solve_static(b, np.zeros_like(rest), fixed | right[:, None] * [1, 0, 0], x0,
                          max_iter=300)
    b.commit(loaded.x)
    released = solve_static(b, np.zeros_like(rest), fixed, loaded.x, max_iter=300)
    # uniaxial stress: sigma = E (eps - eps_p) = sigma_y + H eps_p, so
    # eps_p = (E eps - sigma_y) / (E + H) along x, -eps_p / 2 across (volume kept)
    eps_p = (E * measure(name, stretch) - YIELD) / (E + hardening)
    f = b.deformation_gradient(released.x)
    # Newton stops at 1e-10 of the force scale (sigma_y x 1/4 face share) or at round-off;
    # the modified Newton's error is that over its contraction gap: 1e-9 leaves 100x over the
    # measured 4e-12
    assert np.abs(measure(name, f[:, 0, 0]) - eps_p).max() <= 1e-9
    assert np.abs(measure(name, f[:, 1, 1]) + eps_p / 2).max() <= 1e-9
    stored = b.law.plastic_strain
    assert np.abs(stored - np.diag([eps_p, -eps_p / 2, -eps_p / 2])).max() <= 1e-9
    assert np.abs(b.stress(released.x)).max() <= 1e-6 * YIELD  # unloaded
    assert eps_p > 0.015  # well past yield


def test_below_yield_everything_springs_back():
    b, fixed = unit_cube("linear", 0.0)
    rest = b.elements.rest
    right = rest[:, 0] == 1
    x0 = rest.copy()
    x0[right, 0] = 1.005  # half the yield strain
    loaded = solve_static(b, np.zeros_like(rest), fixed | right[:, None] * [1, 0, 0], x0)
    b.commit(loaded.x)
    assert not b.law.plastic_strain.any() and not b.law.equivalent.any()
    released = solve_static(b, np.zeros_like(rest), fixed, loaded.x)
    assert np.abs(released.x - rest).max() <= 1e-12  # the linear law's one exact step


def test_plasticity_is_refused_in_plane_stress_and_for_neo_hookean():
    nodes, tris = rectangle_triangles(1, 1)
    with pytest.raises(ValueError, match=r"mesh\.plane.*plane stress"):
        ElasticBody.of(TriangleMesh(nodes, tris, Material(E, NU, 1.0, "linear",
                                                          Plasticity(YIELD))))
    nodes, tets = box_tetrahedra(1, 1, 1)
    with pytest.raises(ValueError, match=r"material\.strain.*neo_hookean"):
        ElasticBody.of(TetMesh(nodes, tets, Material(E, NU, 1.0, "neo_hookean",
                                                     Plasticity(YIELD))))


def yielding_bar(name):
    """A 4 x 1 x 1 bar clamped at x = 0, flung by v_x = x / 4 m/s (rho = 1): it yields."""
    nodes, tets = box_tetrahedra(4, 1, 1, 4.0, 1.0, 1.0)
    velocities = np.zeros_like(nodes)
    velocities[:, 0] = nodes[:, 0] / 4.0
    return FemSystem(TetMesh(nodes, tets, Material(E, NU, 1.0, name, Plasticity(YIELD)),
                             velocities=velocities, pinned=np.flatnonzero(nodes[:, 0] == 0)))


def balance_error(name, h, t_end=0.3):
    """max |E_kin + E_stored + dissipated - E(0)| over the run, and the dissipated energy: for
    ideal von Mises plasticity sigma : deps_p = sigma_y da, so dissipation = sigma_y sum V a."""
    system = yielding_bar(name)
    x, v = system.state()
    e0 = system.kinetic_energy(v) + system.potential_energy(x)
    stepper = get_integrator("velocity_verlet")
    state, t, worst = stepper.start(system, 0.0, x, v, h), 0.0, 0.0
    for _ in range(int(round(t_end / h))):
        t, state = system.advance(stepper, t, state, h, 1)  # steps and commits
        xn, vn = stepper.output(system, t, state, h)
        dissipated = YIELD * system.body.elements.volume @ system.body.law.equivalent
        total = system.kinetic_energy(vn) + system.potential_energy(xn) + dissipated
        worst = max(worst, abs(total - e0))
    return worst / e0, dissipated / e0


@pytest.mark.parametrize("name", ["linear", "green"])
def test_a_yielding_bar_balances_its_energy_to_second_order(name):
    coarse, dissipated = balance_error(name, 2e-3)
    fine, _ = balance_error(name, 1e-3)
    assert dissipated > 0.5  # most of the energy goes into plastic work
    # velocity Verlet with the return committed after each step: the balance error is the
    # stepper's O(h^2) (measured 1.8e-4 and 4.5e-5 of E(0), ratio 4.0-4.1; a plastic update
    # lagging by a step would make it O(h))
    assert 3.5 <= coarse / fine <= 4.6
    assert fine <= 1e-4


def test_the_corotated_plastic_force_is_the_slides_convention_not_a_gradient():
    # P = R sigma (slide 001's f = Q sigma n) is dPsi/dF only while eps_p commutes with S;
    # in a bending, yielding bar it does not, and the energy balance stalls at a floor
    # (measured 6.1e-4 of E(0) at h = 1e-3 and 5.9e-4 at 5e-4) instead of shrinking as h^2
    coarse, _ = balance_error("corotated", 1e-3)
    fine, _ = balance_error("corotated", 5e-4)
    assert fine >= 0.8 * coarse and 1e-4 <= fine <= 2e-3
