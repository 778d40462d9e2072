"""taichi's lennard_jones kernels equal refsim's model to round-off: the dimer (all pairs, open
3D), the 2D periodic gas, a 3D periodic box of 2 cells per axis and an open 3D cloud with a
cut-off (the grid's edge cases), per stepper; momentum conserved to round-off."""
import numpy as np
import pytest

pytest.importorskip("taichi")

from refsim_adapters.refsim_engine.engine import RefsimEngine  # noqa: E402
from refsim_adapters.taichi_engine.engine import TaichiEngine  # noqa: E402
from refsim_cases.lennard_jones.lj_dimer import CASE as DIMER  # noqa: E402
from refsim_cases.lennard_jones.lj_gas import CASE as GAS  # noqa: E402
from refsim.scene import Particles, Scene  # noqa: E402
from refsim.scene.lennard_jones import LennardJones  # noqa: E402

EPS = np.finfo(float).eps
INTEGRATORS = ("velocity_verlet", "symplectic_euler", "rk4", "explicit_euler")


def _run(engine, scene, dt, integrator, steps):
    sim = engine.build(scene, dt, integrator)
    sim.step(steps)
    out = sim.observe()
    sim.close()
    return out


def _cloud(n, side, box, cutoff, seed):
    """n particles on a jittered cubic lattice in [0, side)^3 (no overlapping cores), random
    velocities of size ~ 1."""
    per_axis = int(np.ceil(n ** (1 / 3)))
    grid = np.stack(np.meshgrid(*[np.arange(per_axis)] * 3, indexing="ij"), -1).reshape(-1, 3)
    rng = np.random.default_rng(seed)
    x = grid[:n] * (side / per_axis) + rng.uniform(-0.05, 0.05, (n, 3))
    part = LennardJones(cutoff=cutoff, shift=True, box=box)
    return Scene(parts=(Particles(mass=rng.uniform(1, 2, n), position=x,
                                  velocity=rng.normal(0, 1, (n, 3))), part))


def _agree(scene, dt, integrator, steps, bound):
    ref = _run(RefsimEngine(), scene, dt, integrator, steps)
    tai = _run(TaichiEngine(), scene, dt, integrator, steps)
    assert np.max(np.abs(ref["x"] - tai["x"])) <= bound
    assert np.max(np.abs(ref["v"] - tai["v"])) <= bound * 10  # v ~ 10 x the step's motion
    return ref, tai


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_dimer_equals_refsim(integrator):
    p = DIMER.variant_params("small")
    steps = int(round(DIMER.t_end(p) / DIMER.reference_dt(p)))
    # the two sum the same terms in another order: per step a few eps of the state (S ~ r0 =
    # 1.12), kept undamped by the oscillation (Henrici's linear bound): steps x 8 eps x S
    _agree(DIMER.scene(p), DIMER.reference_dt(p), integrator, steps, steps * 8 * EPS * 1.2)


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_gas_equals_refsim_and_conserves_momentum(integrator):
    p = GAS.validate({"particles": 300.0})
    # 4 steps of 5 ms: a round-off difference grows at most like exp(w_T t) = exp(0.8) ~ 2.2
    # over 0.02 time units (w_T = 39, the collision stiffness); the state's scale is the box
    # (|x| <= 21): 4 steps x 8 eps x 21 x 2.2 (x 5 for the per-particle force sums of ~15
    # neighbours, summed in another order)
    ref, tai = _agree(GAS.scene(p), 5e-3, integrator, 4, 4 * 8 * EPS * 21 * 2.2 * 5)
    # momentum: zero at the start; each step adds the rounding of the n force sums
    # (|F| <= ~100, 15 terms each): steps x n x 15 eps x 100 x dt, plus the start's n eps
    bound = 4 * 300 * 15 * EPS * 100 * 5e-3 + 300 * EPS * 4
    assert np.max(np.abs(tai["momentum"])) <= bound


@pytest.mark.parametrize("box, cutoff", [((5.2, 5.2, 5.2), 2.5), (None, 1.8)])
def test_3d_grids_equal_refsim(box, cutoff):
    """A periodic box of 2 cells per axis (its neighbours visited once) and an open cloud."""
    scene = _cloud(40, 5.0, box, cutoff, 3)
    _agree(scene, 2e-3, "velocity_verlet", 5, 5 * 8 * EPS * 6 * 5)
