"""Cucker-Smale and Reynolds accelerations: antisymmetry (zero sum), agreement with a direct
pair sum, the flocking bound, and bad input."""
import numpy as np
import pytest

from refsim.models.flocking import (FlockSystem, cucker_smale_accelerations, diameter_bound,
                                    psi_integral, reynolds_accelerations, velocity_variance)
from refsim.scene import Particles, Scene
from refsim.scene.flocking import Flocking

EPS = np.finfo(float).eps


def _state(seed, n=40, batch=()):
    rng = np.random.default_rng(seed)
    return rng.normal(size=batch + (n, 3)), rng.normal(size=batch + (n, 3))


@pytest.mark.parametrize("seed", range(3))
def test_cucker_smale_pair_sum_vanishes_to_round_off(seed):
    x, v = _state(seed, batch=(2,))
    a = cucker_smale_accelerations(x, v, K=2.0, sigma=0.5, beta=0.4)
    # each term psi (v_j - v_i) is cancelled by its partner; rounding each of the N^2 terms
    # (|psi| <= K / sigma^(2 beta), |v_j - v_i| <= 2 max|v|) leaves at most N eps of a term
    n = x.shape[-2]
    term = 2.0 / 0.5 ** 0.8 * 2 * np.abs(v).max()
    assert np.abs(a.sum(axis=-2)).max() <= n * EPS * term


def test_cucker_smale_matches_the_direct_double_sum():
    x, v = _state(7, n=6)
    direct = np.zeros_like(x)
    for i in range(6):  # the definition itself, term by term (a test oracle, not a hot path)
        for j in range(6):
            psi = 1.5 / (0.7 ** 2 + np.sum((x[i] - x[j]) ** 2)) ** 0.3
            direct[i] += psi * (v[j] - v[i]) / 6
    got = cucker_smale_accelerations(x, v, 1.5, 0.7, 0.3)
    assert np.abs(got - direct).max() <= 1e-14 * np.abs(direct).max() * 6


def test_reynolds_rules_match_their_definition_and_do_not_sum_to_zero():
    x, v = _state(3, n=8)
    got = reynolds_accelerations(x, v, 1.5, 0.2, 0.7, 0.3)
    direct = np.zeros_like(x)
    for i in range(8):
        near = [j for j in range(8) if 0 < np.linalg.norm(x[j] - x[i]) < 1.5]
        if near:
            sep = sum((x[i] - x[j]) / np.sum((x[i] - x[j]) ** 2) for j in near)
            direct[i] = (0.2 * sep + 0.7 * (v[near].mean(axis=0) - v[i])
                         + 0.3 * (x[near].mean(axis=0) - x[i]))
    assert np.abs(got - direct).max() <= 1e-13 * np.abs(direct).max()


def test_reynolds_alignment_does_not_keep_the_mean_velocity():
    # three birds on a line, 1 m apart, radius 1.5: the middle one has two neighbours, the
    # ends one; alignment alone sums to (v1 - v0) + (v1 - v2) + ((v0 + v2)/2 - v1)
    # = v1 - (v0 + v2)/2: per-bird means break the pair antisymmetry
    x = np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0]])
    v = np.array([[1.0, 0, 0], [0.0, 0, 0], [0.0, 2.0, 0]])
    got = reynolds_accelerations(x, v, 1.5, 0.0, 1.0, 0.0)
    expected = v[1] - 0.5 * (v[0] + v[2])
    assert np.allclose(got.sum(axis=0), expected, rtol=0, atol=4 * EPS)
    assert np.linalg.norm(expected) > 0.5


def test_flock_system_batches_and_flattens():
    x, v = _state(1, n=5, batch=(3,))
    system = FlockSystem(Flocking(K=1.0, sigma=1.0, beta=0.25), 5)
    flat = system.accel(0.0, x.reshape(3, -1), v.reshape(3, -1)).reshape(x.shape)
    # same operations: FlockSystem.accel reshapes and calls this function
    assert np.array_equal(flat, cucker_smale_accelerations(x, v, 1.0, 1.0, 0.25))


def test_diameter_bound_solves_its_defining_integral():
    x, v = _state(2, n=10)
    d_inf = diameter_bound(x, v, 1.0, 1.0, 0.25)
    start = 2 * np.sqrt(np.sum((x - x.mean(axis=0)) ** 2))
    half_integral = 0.5 * psi_integral(start, d_inf, 1.0, 1.0, 0.25)
    assert half_integral == pytest.approx(np.sqrt(np.sum((v - v.mean(axis=0)) ** 2)), rel=1e-9)
    # beta = 0: psi = K constant, (1/2) K (D - start) = |V0|: D = start + 2 |V0| / K
    assert diameter_bound(x, v, 2.0, 1.0, 0.0) == pytest.approx(
        start + 2 * np.sqrt(np.sum((v - v.mean(axis=0)) ** 2)) / 2.0, rel=1e-9)
    assert velocity_variance(v) > 0


@pytest.mark.parametrize("field,value", [("K", 0.0), ("sigma", -1.0), ("beta", -0.1),
                                         ("radius", 0.0), ("alignment", -1.0),
                                         ("rule", "vicsek")])
def test_bad_flocking_parameters_name_the_field(field, value):
    with pytest.raises(ValueError, match=f"flocking.{field}"):
        Flocking(**{field: value})


def test_scene_finds_its_flocking_part():
    part = Flocking()
    scene = Scene(parts=(Particles(mass=[1.0, 1.0], position=np.eye(2, 3)), part))
    assert scene.part(Flocking) is part and "flocking" in scene.features()
