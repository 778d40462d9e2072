"""The float paths of one body on one spring or one KKT rod (refsim/models/one_spring.py,
one_rod.py) give the numpy path's doubles bit for bit: random springs (stiff and soft, with and
without rest length, damping, drag and gravity), a body on its anchor (|d| = 0), random rods
off their length, and the batch path unchanged."""
import numpy as np
import pytest

from refsim.models.forces import SpringSet
from refsim.models.joints import RodSet
from refsim.models.system import ParticleSystem
from refsim.scene import Spring


def _system(rng, trial):
    spring = Spring(body=0, stiffness=10 ** rng.uniform(1, 6),
                    rest_length=rng.uniform(0, 2) * (trial % 3 != 0),
                    damping=rng.uniform(0, 5) * (trial % 2), anchor=tuple(rng.normal(size=3)))
    return ParticleSystem([rng.uniform(0.1, 3)], rng.normal(size=3) * (trial % 4 != 0),
                          drag=rng.uniform(0, 1) * (trial % 5 == 0),
                          springs=SpringSet.from_scene([spring]))


@pytest.mark.parametrize("seed", range(4))
def test_float_path_equals_numpy_path_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    for trial in range(500):
        system = _system(rng, trial)
        assert system.one_spring is not None
        x = np.array(system.springs.anchor[0]) if trial == 0 else rng.normal(size=3) * 3
        v = rng.normal(size=3)
        fast = system.accel(0.0, x, v)
        system.one_spring = None  # the numpy path
        assert np.array_equal(fast, system.accel(0.0, x, v))


def test_batches_and_two_springs_keep_the_numpy_path():
    rng = np.random.default_rng(9)
    system = _system(rng, 1)
    x, v = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    batch = system.accel(0.0, x, v)
    assert np.array_equal(batch[2], system.accel(0.0, x[2], v[2]))
    two = SpringSet.from_scene([Spring(body=0, stiffness=1.0, rest_length=0.0),
                                Spring(body=0, stiffness=2.0, rest_length=0.0)])
    assert ParticleSystem([1.0], (0, 0, 0), springs=two).one_spring is None


@pytest.mark.parametrize("seed", range(2))
def test_rod_float_path_equals_numpy_path_bit_for_bit(seed):
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
        assert np.array_equal(fast, system.accel(0.0, x, v))
