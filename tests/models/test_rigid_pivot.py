"""PivotedRigidSystem: parallel axis, vectorisation over bodies and batch, the pivot holding
the centre of mass on its sphere, conservation under RK4; the refsim pivots group's claims,
supports, settings and observation contract."""
import numpy as np
import pytest

from refsim.integrators import get_integrator
from refsim.models.rigid_orientation import FORMULATIONS, get_formulation
from refsim.models.rigid_pivot import PivotedRigidSystem, pivot_inertia
from refsim.observation import check_observation
from refsim.registry import get_engine
from refsim.scene import RigidBodies, Scene
from refsim.scene.pivots import RigidPivots

G = np.array([0.0, 0.0, -9.81])
EPS = np.finfo(float).eps


def _bodies(n=3, seed=1):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    return {"mass": rng.uniform(1, 2, n), "inertia": np.array([np.diag(rng.uniform(0.5, 2, 3))
                                                             for _ in range(n)]),
                "com_offset": rng.normal(size=(n, 3)), "anchor": rng.normal(size=(n, 3)),
                "q": q / np.linalg.norm(q, axis=1)[:, None], "w": rng.normal(size=(n, 3))}


def _system(b, formulation="quat_exp"):
    return PivotedRigidSystem(b["mass"], b["inertia"], b["com_offset"], b["anchor"], G,
                              get_formulation(formulation))


def test_parallel_axis_gives_a_rod_about_its_end_m_l2_over_3():
    m, length = 2.0, 3.0
    rod = np.diag([m * length ** 2 / 12] * 2 + [0.0])[None]
    about_end = pivot_inertia(rod, [m], [[0.0, 0.0, -length / 2]])[0]
    np.testing.assert_allclose(np.diag(about_end), [m * length ** 2 / 3] * 2 + [0.0],
                               rtol=4 * EPS)


def test_accel_is_vectorised_over_bodies_and_a_batch():
    b = _bodies()
    system = _system(b)
    x, w = system.configuration(b["q"]), b["w"]
    together = system.accel(0.0, x, w)
    for i in range(3):
        one = _system({k: v[i:i + 1] for k, v in b.items()})
        np.testing.assert_allclose(one.accel(0.0, x[i:i + 1], w[i:i + 1])[0], together[i],
                                   rtol=1e-13, atol=1e-13)
    batch = system.accel(0.0, np.stack([x, x]), np.stack([w, 2 * w]))
    # same operations per instance: elementwise ufuncs and per-body 3x3 matmuls, same strides
    np.testing.assert_array_equal(batch[0], together)
    assert batch.shape == (2, 3, 3)


@pytest.mark.parametrize("formulation", sorted(FORMULATIONS))
def test_centre_of_mass_stays_on_its_sphere(formulation):
    b = _bodies()
    system = _system(b, formulation)
    stepper = get_integrator("symplectic_euler")
    _, (x, _w) = stepper.advance(system, 0.0, stepper.start(system, 0.0, system.configuration(
        b["q"]), b["w"], 1e-2), 1e-2, 100)
    radius = np.linalg.norm(system.position(x) - b["anchor"], axis=1)
    expected = np.linalg.norm(b["com_offset"], axis=1)
    if FORMULATIONS[formulation].orthogonal:  # R is a rotation: |R c| = |c| to round-off
        np.testing.assert_allclose(radius, expected, rtol=1e-13)
    else:  # the printed matrix stretches c with R: only its defect bounds the change
        stretch = np.sqrt(1 + system.defect(x))
        assert np.all(radius <= expected * stretch * (1 + 1e-12))


def test_rk4_conserves_energy_and_vertical_momentum():
    b = _bodies()
    system = _system(b)
    stepper = get_integrator("rk4")
    x0, w0 = system.configuration(b["q"]), b["w"]
    _, (x, w) = stepper.advance(system, 0.0, (x0, w0), 1e-3, 1000)
    # RK4 at |w| dt <~ 0.01: relative errors ~ (|w| dt)^4 t |w| << 1e-8
    np.testing.assert_allclose(system.energy(x, w), system.energy(x0, w0), rtol=1e-8)
    lz0 = system.angular_momentum(x0, w0)[:, 2]
    np.testing.assert_allclose(system.angular_momentum(x, w)[:, 2], lz0, rtol=1e-8,
                               atol=1e-8 * np.abs(lz0).max())


def test_bad_input():
    b = _bodies()
    with pytest.raises(ValueError, match="com_offset and anchor"):
        PivotedRigidSystem(b["mass"], b["inertia"], b["com_offset"][:2], b["anchor"], G,
                           get_formulation("quat_exp"))


def _pivot_scene(pivoted=(0, 1)):
    b = _bodies(2)
    rigid = RigidBodies(mass=b["mass"], inertia=b["inertia"], position=np.zeros((2, 3)),
                        orientation=[[1.0, 0, 0, 0]] * 2, angular_velocity=b["w"])
    k = len(pivoted)
    pivots = RigidPivots(body=list(pivoted), body_point=b["com_offset"][:k],
                         anchor=b["com_offset"][:k])
    return Scene(parts=(rigid, pivots), gravity=tuple(G))


def test_pivots_group_claims_supports_and_declares_not_symplectic():
    engine = get_engine("refsim")
    scene = _pivot_scene()
    assert engine.group_for(scene).name == "pivots"
    assert engine.supports(scene, "rk4") is None
    assert "every rigid body pivoted" in engine.supports(_pivot_scene((1,)), "rk4")
    for formulation in engine.formulations(scene):
        sim = engine.build(scene, 1e-3, "symplectic_euler", formulation)
        assert check_observation(sim.observe(), scene) == []
        sim.step(2)
        assert check_observation(sim.observe(), scene) == []
        settings = sim.settings()
        assert settings["integrator"]["symplectic"] is False
        assert settings["formulation"] == formulation and "symplectic_note" in settings
