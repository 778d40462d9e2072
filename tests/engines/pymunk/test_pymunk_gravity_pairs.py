"""pymunk's n-body gravity (adapters/pymunk_engine/groups/gravity_pairs.py): point-mass bodies
kicked by their velocity_func with the pair acceleration at the drifted positions, on the Kepler
orbit and the figure-eight (both planar), against refsim's symplectic_euler_dk driven by the
same kernel (refsim.models.nbody_gravity) and the exact orbits.

Kepler: G = 1, a = 1, masses summing to M = 1: exact period 2 pi a^1.5 / sqrt(G M) = 2 pi,
started at true anomaly pi/2 (at an apsis symplectic Euler's return error falls at order 2,
hiding its order 1: see tests/engines/mujoco/test_mujoco_gravity_pairs.py).
Figure-eight: Chenciner-Montgomery (docs/models.md#fields-kepler-and-figure-eight), G = m = 1,
period 6.32591398.
pymunk is imported on purpose: CI must have every engine (fail, never skip).
"""
import gravity_scenes
import numpy as np
import pymunk  # noqa: F401  (fail, never skip, without the engine)
from gravity_scenes import (  # noqa: F401
    EIGHT_PERIOD,
    EPS,
    ORDER_SLACK,
    TWO_PI,
    PairSystem,
    angular_momentum,
    energy,
    figure_eight,
    fitted_orders,
    in_house,
    kepler,
)

from refsim.engine import IntegratorInfo
from refsim.registry import get_engine
from refsim.scene import Scene
from refsim.scene.particles import Particles

ENGINE = get_engine("pymunk")
INTEGRATOR = "symplectic_euler_dk"


def run(scene, integrator, variant, period, steps):
    return gravity_scenes.run(ENGINE, scene, integrator, variant, period, steps)


def return_error(scene, integrator, variant, period, steps):
    return gravity_scenes.return_error(ENGINE, scene, integrator, variant, period, steps)


def test_group_claims_planar_gravity_scenes_and_refuses_3d_ones():
    scene = kepler(0.5)
    assert ENGINE.group_for(scene).name == "gravity_pairs"
    assert ENGINE.supports(scene, INTEGRATOR) is None
    s = ENGINE.build(scene, 0.01, INTEGRATOR, "").settings()
    assert "one Python call per step" in s["python_per_step"]
    assert s["space"]["damping"] == 1.0 and list(s["space"]["gravity"]) == [0.0, 0.0]
    assert IntegratorInfo.of(s).order == 1 and s["plane"].startswith("refsim (x, y)")
    p = scene.particles
    tilted = Scene(bodies=Particles(p.mass, p.position, p.velocity + [0.0, 0.0, 0.1]),
                   extra=scene.extra)
    assert ENGINE.supports(tilted, INTEGRATOR).startswith("pymunk is 2D")


def test_refsim_drift_kick_bit_for_bit():
    """pymunk drifts x += h v, then update_velocity adds h (0 + a(x_{k+1})) to v * 1.0^h:
    refsim's symplectic_euler_dk arithmetic, bit for bit over 1000 steps (measured, any
    masses: the acceleration is added as such, no f / m)."""
    for scene, period in ((kepler(0.5), TWO_PI), (figure_eight(), EIGHT_PERIOD)):
        steps = 1000
        obs = run(scene, INTEGRATOR, "", period, steps)
        x, v = in_house(scene, INTEGRATOR, period / steps, steps)
        assert np.array_equal(obs["x"], x) and np.array_equal(obs["v"], v)


def test_xz_plane_scene_maps_onto_pymunk_plane():
    """The same orbit turned into the x-z plane (a 3D scene at y = 0) gives the same numbers:
    only the axes are renamed."""
    scene = kepler(0.5)
    swap = [0, 2, 1]
    p = scene.particles
    xz = Scene(bodies=Particles(p.mass, p.position[:, swap], p.velocity[:, swap]),
               extra=scene.extra)
    a, b = run(scene, INTEGRATOR, "", TWO_PI, 200), run(xz, INTEGRATOR, "", TWO_PI, 200)
    assert np.array_equal(a["x"], b["x"][:, swap]) and np.array_equal(a["v"], b["v"][:, swap])


def test_kepler_return_error_falls_at_order_one():
    """e = 0.5, T/400..T/1600: 0.135, 0.067, 0.033 (measured orders 1.01, 1.01)."""
    scene = kepler(0.5)
    errors = [return_error(scene, INTEGRATOR, "", TWO_PI, n) for n in (400, 800, 1600)]
    assert np.all(np.abs(fitted_orders(errors) - 1.0) <= ORDER_SLACK), errors


def test_energy_bounded_at_order_one_and_angular_momentum_exact():
    """Drift-kick with central pair forces keeps L = sum m x x v exactly (the drift keeps x x v,
    the pair torques cancel in the kick), so |dL| is round-off: steps x eps x sum m|x||v|
    (<= 1). The energy error oscillates with an O(h) amplitude (modified energy kept): its max
    over 5 periods halves with h (order 1 +- 0.3) and does not grow: the last two periods' max
    stays within 1.5x the first's (the spread comes from where the pericentre falls on the step
    grid; a first-order non-symplectic step grows 2.4x over the same span)."""
    scene = kepler(0.5)
    m, maxima = scene.masses, []
    for steps in (400, 800):
        sim = ENGINE.build(scene, TWO_PI / steps, INTEGRATOR, "")
        o0 = sim.observe()
        de, dl = [], []
        for _ in range(5 * steps):
            sim.step(1)
            o = sim.observe()
            de.append(abs(energy(o, m) - energy(o0, m)))
            dl.append(np.abs(angular_momentum(o, m) - angular_momentum(o0, m)).max())
        per_period = np.array(de).reshape(5, steps).max(axis=1)
        assert per_period[3:].max() <= 1.5 * per_period[0]
        assert max(dl) <= 5 * steps * EPS
        maxima.append(per_period.max())
    assert abs(np.log2(maxima[0] / maxima[1]) - 1.0) <= ORDER_SLACK


def test_figure_eight_returns_within_the_order_bound():
    """Order 1: the return error halves with h, e(h/2) <= e(h) / 2^(1 - 0.3) (measured 0.027,
    0.013), far above the ~1e-8 floor of the 8-decimal initial state and period."""
    scene = figure_eight()
    coarse, fine = (return_error(scene, INTEGRATOR, "", EIGHT_PERIOD, n) for n in (400, 800))
    assert fine <= coarse / 2.0 ** (1.0 - ORDER_SLACK) and fine > 1e-6
