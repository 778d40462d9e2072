"""The emitter's schedule (births, removals, counts, slots) and its exact discrete paths,
checked against the rules themselves and against the steppers run on one particle."""
import numpy as np
import pytest

from refsim.integrators import get_integrator
from refsim.models import emitter as em
from refsim.models.system import ParticleSystem
from refsim.scene import Scene
from refsim.scene.emitter import Emitter, spawn_uniforms

EPS = np.finfo(float).eps


@pytest.mark.parametrize("h", [1e-2, 3e-3, 0.02, 0.05])
def test_births_are_the_first_boundary_at_or_after_i_over_rate(h):
    e = Emitter(rate=37.0, lifetime=0.7)
    ids = np.arange(500)
    n = em.birth_steps(e, h, ids)
    assert np.all(n * h >= ids / e.rate)
    assert np.all((n == 0) | ((n - 1) * h < ids / e.rate))
    counts = em.emitted_count(e, h, np.arange(200))
    assert np.array_equal(counts, [(n <= k).sum() for k in range(200)])


@pytest.mark.parametrize("h", [1e-2, 3e-3, 0.02, 0.05])
def test_alive_counts_fit_the_capacity_and_the_step_rounded_rate(h):
    e = Emitter(rate=37.0, lifetime=0.7)
    steps = em.life_steps(e, h)
    assert steps * h >= e.lifetime > (steps - 1) * h
    alive = [em.alive_ids(e, h, n) for n in range(400)]
    assert max(len(a) for a in alive) <= em.capacity(e, h)
    for n, a in enumerate(alive):  # consecutive, so slots i mod capacity never collide
        assert np.array_equal(a, np.arange(a[0], a[0] + len(a))) if len(a) else True
        assert abs(len(a) - em.continuum_alive(e, n * h)) <= em.count_bound(e, h)


def test_as_printed_births_k_per_step():
    e = Emitter(per_step=3)
    assert np.array_equal(em.birth_steps(e, 0.01, np.arange(7), "as_printed"),
                          [0, 0, 0, 1, 1, 1, 2])
    assert em.emitted_count(e, 0.01, 4, "as_printed") == 15


@pytest.mark.parametrize("name", ["explicit_euler", "symplectic_euler", "symplectic_euler_dk",
                                  "midpoint", "rk4", "velocity_verlet", "stormer_verlet",
                                  "leapfrog", "implicit_euler"])
def test_discrete_path_is_what_the_stepper_does(name):
    g, h, k = np.array([0.3, 0.0, -9.81]), 0.01, 300
    x0, v0 = np.array([[0.1, 0.2, 0.3]]), np.array([[1.0, -0.5, 5.0]])
    system, stepper = ParticleSystem([1.0], g), get_integrator(name)
    state = stepper.start(system, 0.0, x0.ravel(), v0.ravel(), h)
    _, state = stepper.advance(system, 0.0, state, h, k)
    x, v = stepper.output(system, k * h, state, h)
    xe, ve = em.discrete_path(name, x0, v0, g, h, np.array([k]))
    # k steps, each rounding a state of size S = |x| + |v| k h by eps: n eps S
    scale = np.abs(xe).max() + np.abs(ve).max() * k * h
    assert np.abs(x - xe.ravel()).max() <= k * EPS * scale
    assert np.abs(v - ve.ravel()).max() <= k * EPS * np.abs(ve).max()


def test_spawn_draws_depend_on_seed_and_id_only():
    a = spawn_uniforms(4, np.arange(100))
    # same operations: counter-based draws, the same seed and ids
    assert np.array_equal(a[40:60], spawn_uniforms(4, np.arange(40, 60)))
    assert not np.array_equal(a, spawn_uniforms(5, np.arange(100)))
    assert a.min() >= 0 and a.max() < 1 and abs(a.mean() - 0.5) < 0.05  # 300 draws: 3 sigma
    x0, v0 = Emitter(velocity=(0, 0, 5), spread=1.0).spawn_states(np.arange(100))
    assert np.all(np.abs(v0 - (0, 0, 5)) <= 1.0) and np.all(x0 == 0)


@pytest.mark.parametrize("field,value", [("rate", 0.0), ("lifetime", -1.0), ("spread", -1.0),
                                         ("seed", -1), ("per_step", 0), ("per_step", 1.5)])
def test_bad_emitter_parameters_name_the_field(field, value):
    with pytest.raises(ValueError, match=f"emitter.{field}"):
        Emitter(**{field: value})


def test_scene_finds_its_emitter():
    part = Emitter()
    scene = Scene(parts=(part,), gravity=(0, 0, -9.81))
    assert scene.part(Emitter) is part and scene.moving_kind() == "emitter"
    with pytest.raises(ValueError, match="formulation"):
        em.capacity(part, 0.01, "printed")
