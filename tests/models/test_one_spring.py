"""The float paths of one body on one spring or one KKT rod (refsim/models/one_spring.py,
one_rod.py) against the numpy path: random springs (stiff and soft, with and without rest
length, damping, drag and gravity), a body on its anchor (|d| = 0), random rods off their
length, and the batch path unchanged.

Not bit for bit: the float paths sum each 3-component dot product as (a0 b0 + a2 b2) + a1 b1,
which is numpy's einsum order on x86-64 (SSE baseline: equal there, measured), but on aarch64
einsum fuses its multiply-adds, so the paths are not the same operations on every machine.
The bounds below are per-path rounding bounds, doubled, some 1e-15 of the terms' sizes: a
wrong term or parameter fails them (0.1 % of k moves a by 1e-3 k |d - L0| / m)."""
import numpy as np
import pytest

from refsim.models.forces import SpringSet
from refsim.models.joints import RodSet
from refsim.models.system import ParticleSystem
from refsim.scene import Spring
from ulp import assert_ulp

# Per path, against exact arithmetic: |d|^2 within 1.5 eps (three roundings of positive
# terms, fused or not), |d| within 1.25 eps, u = d / |d| within 1.75 eps; s = -k (|d| - L0)
# within 2.25 eps of k (|d| + L0), f = s u (and the damper's c (dv . u) u likewise, its dot
# within 1.5 eps of sum |dv_j u_j|) within 5 eps of the terms' sizes; a = f / m + g two more
# roundings: 8 eps of the scale S_i below per path, so the paths are 16 eps S_i apart at most.
SPRING_ULPS = 16


def _spring_scale(system, x, v):
    """S_i = (k (|d| + L0) + c sum_j |dv_j u_j|) |u_i| / m + drag |v_i| / m + |g_i|."""
    s = system.springs
    d = x - s.anchor[0]
    length = np.sqrt(np.sum(d * d))
    u = np.abs(d) / length if length > 0 else np.zeros(3)
    spring = s.stiffness[0] * (length + s.rest[0]) + s.damping[0] * np.sum(np.abs(v) * u)
    inv_m = system.inv_m[0, 0]
    return (spring * u + system.drag * np.abs(v)) * inv_m + np.abs(system.gravity)


# Per path: each dot within 1.5 eps of its sum |a_j b_j| (r.r, v.v, r.v, r.f); the numerator
# r.f/m - rhs within 3 eps of T = sum|r_j f_j|/m + |v|^2 + 2 w sum|r_j v_j| + w^2/2 (|r|^2 + L^2)
# from the dots and 5 eps from its own five roundings, lam = num / (|r|^2/m) within 10 eps of
# Lam = T m / |r|^2 (|lam| <= Lam), a = (f - lam r) / m within 10 eps (|f_i| + Lam |r_i|) / m:
# the paths are 20 eps of that apart at most.
ROD_ULPS = 20


def _rod_scale(system, x, v):
    rods, m, w = system.rods, system.masses[0], system.rods.baumgarte
    r = x - rods.anchor[0]
    f = system.weight[0] - system.drag * v
    rr = np.sum(r * r)
    size = (np.sum(np.abs(r * f)) / m + np.sum(v * v) + 2 * w * np.sum(np.abs(r * v))
            + 0.5 * w * w * (rr + rods.length_squared[0]))
    return (np.abs(f) + size * m / rr * np.abs(r)) / m


def _system(rng, trial):
    spring = Spring(body=0, stiffness=10 ** rng.uniform(1, 6),
                    rest_length=rng.uniform(0, 2) * (trial % 3 != 0),
                    damping=rng.uniform(0, 5) * (trial % 2), anchor=tuple(rng.normal(size=3)))
    return ParticleSystem([rng.uniform(0.1, 3)], rng.normal(size=3) * (trial % 4 != 0),
                          drag=rng.uniform(0, 1) * (trial % 5 == 0),
                          springs=SpringSet.from_scene([spring]))


@pytest.mark.parametrize("seed", range(4))
def test_float_path_equals_numpy_path_to_round_off(seed):
    rng = np.random.default_rng(seed)
    for trial in range(500):
        system = _system(rng, trial)
        assert system.one_spring is not None
        x = np.array(system.springs.anchor[0]) if trial == 0 else rng.normal(size=3) * 3
        v = rng.normal(size=3)
        fast = system.accel(0.0, x, v)
        system.one_spring = None  # the numpy path
        assert_ulp(fast, system.accel(0.0, x, v), SPRING_ULPS,
                   "the einsum dot products' order and fusing: see SPRING_ULPS",
                   scale=_spring_scale(system, x, v))


def test_batches_and_two_springs_keep_the_numpy_path():
    rng = np.random.default_rng(9)
    system = _system(rng, 1)
    x, v = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    batch = system.accel(0.0, x, v)  # numpy; one flat state below takes the float path
    assert_ulp(batch[2], system.accel(0.0, x[2], v[2]), SPRING_ULPS,
               "the einsum dot products' order and fusing: see SPRING_ULPS",
               scale=_spring_scale(system, x[2], v[2]))
    two = SpringSet.from_scene([Spring(body=0, stiffness=1.0, rest_length=0.0),
                                Spring(body=0, stiffness=2.0, rest_length=0.0)])
    assert ParticleSystem([1.0], (0, 0, 0), springs=two).one_spring is None


@pytest.mark.parametrize("seed", range(2))
def test_rod_float_path_equals_numpy_path_to_round_off(seed):
    rng = np.random.default_rng(100 + seed)
    for trial in range(500):
        anchor = rng.normal(size=(1, 3))
        rods = RodSet(body=np.array([0]), anchor=anchor, length=rng.uniform(0.5, 2, 1),
                      baumgarte=rng.uniform(0, 50))
        system = ParticleSystem([rng.uniform(0.1, 3)], rng.normal(size=3) * 9.81,
                                drag=rng.uniform(0, 1) * (trial % 3 == 0), rods=rods)
        assert system.one_spring is not None
        x, v = anchor[0] + rng.normal(size=3), rng.normal(size=3)
        fast = system.accel(0.0, x, v)
        system.one_spring = None
        assert_ulp(fast, system.accel(0.0, x, v), ROD_ULPS,
                   "the einsum dot products' order and fusing: see ROD_ULPS",
                   scale=_rod_scale(system, x, v))
