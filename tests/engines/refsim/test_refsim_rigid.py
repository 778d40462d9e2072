"""The refsim engine's rigid group: claims, formulations, integrators, observation contract,
settings, exact free fall, and many bodies in one step."""
import numpy as np
import pytest

from refsim.observation import check_observation
from refsim.registry import get_engine
from refsim.scene import Body, Scene
from refsim.scene import Particles
from refsim.scene.rigid import RigidBodies

EPS = np.finfo(float).eps
G = (0.0, 0.0, -9.81)


def rigid_scene(n=2, gravity=G, seed=0):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    return Scene(parts=(RigidBodies(
        mass=rng.uniform(1, 2, n), inertia=np.tile(np.diag([1.0, 2.0, 3.0]), (n, 1, 1)),
        position=rng.normal(size=(n, 3)), orientation=q / np.linalg.norm(q, axis=1)[:, None],
        velocity=rng.normal(size=(n, 3)), angular_velocity=rng.normal(size=(n, 3))),), gravity=gravity)


@pytest.fixture(scope="module")
def engine():
    return get_engine("refsim")


def test_group_claims_rigid_scenes_only(engine):
    scene = rigid_scene()
    assert engine.group_for(scene).name == "rigid"
    assert engine.formulations(scene) == ("quat_exp", "quat_normalised", "matrix_printed",
                                          "matrix_polar")
    assert engine.offered_integrators(scene) == ("symplectic_euler", "explicit_euler",
                                                 "midpoint", "rk4", "implicit_midpoint")
    assert engine.supports(scene, "rk4") is None
    assert "offers no integrator" in engine.supports(scene, "implicit_euler")
    particles = Scene(parts=(Particles.of((Body(mass=1.0, position=(0, 0, 0)),)),), gravity=G)
    assert engine.group_for(particles) is None or engine.group_for(particles).name != "rigid"


@pytest.mark.parametrize("formulation", ["quat_exp", "quat_normalised", "matrix_printed",
                                         "matrix_polar"])
@pytest.mark.parametrize("integrator", ["symplectic_euler", "rk4", "implicit_midpoint"])
def test_observation_follows_the_contract(engine, formulation, integrator):
    scene = rigid_scene()
    sim = engine.build(scene, 0.01, integrator, formulation)
    sim.step(5)
    obs = sim.observe()
    assert check_observation(obs, scene) == []
    assert obs["orientation_defect"].shape == (2,) and np.ndim(obs["energy"]) == 0
    assert np.allclose(np.linalg.norm(obs["q"], axis=1), 1.0, rtol=0, atol=4 * EPS)
    settings = sim.settings()
    assert settings["formulation"] == formulation and settings["formulation_description"]
    assert settings["integrator"]["name"] == integrator
    assert settings["angular_damping"] == 0.0 and settings["velocity_clamp"] is None


def test_symplectic_euler_free_fall_is_the_exact_discrete_sum(engine):
    """docs/engine_notes.md#exact-free-fall-under-each-stepper: z_k = z0 + k dt v0
    - k(k+1)/2 dt^2 g under semi-implicit Euler; a few roundings per step of O(1) numbers:
    1e-12 m over 100 steps is k x 40 eps of a 3 m scale."""
    scene, dt, k = rigid_scene(), 0.01, 100
    sim = engine.build(scene, dt, "symplectic_euler", "quat_exp")
    sim.step(k)
    rigid = scene.part(RigidBodies)
    expected = rigid.position + k * dt * rigid.velocity + k * (k + 1) / 2 * dt * dt * np.array(G)
    assert np.max(np.abs(sim.observe()["x"] - expected)) <= 1e-12


def test_matrix_formulation_observes_the_polar_quaternion(engine):
    scene = rigid_scene(gravity=(0.0, 0.0, 0.0))
    exp_sim = engine.build(scene, 1e-3, "rk4", "quat_exp")
    polar_sim = engine.build(scene, 1e-3, "rk4", "matrix_polar")
    for sim in (exp_sim, polar_sim):
        sim.step(100)
    q_exp, q_polar = exp_sim.observe()["q"], polar_sim.observe()["q"]
    same = np.minimum(np.abs(q_exp - q_polar).max(axis=1), np.abs(q_exp + q_polar).max(axis=1))
    # both RK4 with their map's dexpinv: agree to their O(h^4) errors (h |w| ~ 2e-3)
    assert np.max(same) <= 1e-10


def test_many_bodies_step_together_like_one(engine):
    """10^3 bodies in one Sim (one numpy call per stage) equal the same bodies run alone."""
    many = rigid_scene(n=1000, seed=3)
    sim = engine.build(many, 0.01, "rk4", "quat_exp")
    sim.step(10)
    pick = [0, 517, 999]
    rigid = many.part(RigidBodies)
    one = Scene(parts=(RigidBodies(
        mass=rigid.mass[pick], inertia=rigid.inertia[pick], position=rigid.position[pick],
        orientation=rigid.orientation[pick], velocity=rigid.velocity[pick],
        angular_velocity=rigid.angular_velocity[pick]),), gravity=G)
    alone = engine.build(one, 0.01, "rk4", "quat_exp")
    alone.step(10)
    for key in ("x", "v", "q", "w"):
        assert np.allclose(sim.observe()[key][pick], alone.observe()[key], rtol=0, atol=1e-14)


def test_matrix_printed_reports_its_growing_defect(engine):
    scene = rigid_scene(gravity=(0.0, 0.0, 0.0))
    sim = engine.build(scene, 0.01, "symplectic_euler", "matrix_printed")
    sim.step(200)
    obs = sim.observe()
    assert np.all(obs["orientation_defect"] > 1e-3) and np.all(obs["det_defect"] > 1e-3)
