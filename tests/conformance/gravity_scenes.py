"""Scenes and in-house references shared by the engines' n-body gravity tests (MuJoCo,
pybullet, pymunk; tests/conformance/test_conformance_gravity_pairs.py and each engine's
test_<engine>_gravity_pairs.py): a Kepler pair started off an apsis, the figure-eight, the
in-house steppers on the same pair kernel, and the invariants. Imported by basename
(tests/engines/conftest.py puts this directory on the path)."""
import numpy as np

from refsim.integrators import get_integrator
from refsim.models.nbody_gravity import pair_accelerations, potential_energy
from refsim.scene import Scene
from refsim.scene.gravity_pairs import GravityPairs
from refsim.scene.particles import Particles

EPS = np.finfo(float).eps
TWO_PI = 2.0 * np.pi
EIGHT_PERIOD = 6.32591398
ORDER_SLACK = 0.3  # fitted order vs nominal on a clean asymptotic range


def kepler(e, masses=(0.75, 0.25), anomaly=np.pi / 2):
    """Two bodies on a Kepler orbit of eccentricity e, a = 1, G = 1, centre of mass at rest at
    the origin, in the x-y plane; relative state at true anomaly `anomaly`."""
    m = np.array(masses, float)
    M, p = m.sum(), 1.0 - e * e
    r = p / (1.0 + e * np.cos(anomaly))
    rel_x = r * np.array([np.cos(anomaly), np.sin(anomaly), 0.0])
    rel_v = np.sqrt(M / p) * np.array([-np.sin(anomaly), e + np.cos(anomaly), 0.0])
    x = np.array([-m[1] / M * rel_x, m[0] / M * rel_x])
    v = np.array([-m[1] / M * rel_v, m[0] / M * rel_v])
    return Scene(parts=(Particles(m, x, v), GravityPairs(G=1.0, softening=0.0)))


def figure_eight():
    x1 = np.array([0.97000436, -0.24308753, 0.0])
    v3 = np.array([-0.93240737, -0.86473146, 0.0])
    return Scene(parts=(Particles(np.ones(3), [x1, -x1, np.zeros(3)], [-v3 / 2, -v3 / 2, v3]), GravityPairs(G=1.0, softening=0.0)))


class PairSystem:
    """The in-house steppers' system for the same kernel (flat state, as refsim's engine)."""

    velocity_dependent, linear = False, False

    def __init__(self, masses):
        self.masses = np.asarray(masses, float)

    def accel(self, t, x, v):
        return pair_accelerations(x.reshape(-1, 3), self.masses).reshape(x.shape)


def in_house(scene, integrator, dt, steps):
    stepper, system = get_integrator(integrator), PairSystem(scene.part(Particles).mass)
    state = stepper.start(system, 0.0, scene.part(Particles).position.ravel().copy(),
                          scene.part(Particles).velocity.ravel().copy(), dt)
    _, state = stepper.advance(system, 0.0, state, dt, steps)
    x, v = stepper.output(system, steps * dt, state, dt)
    return x.reshape(-1, 3), v.reshape(-1, 3)


def in_house_step(masses, integrator, x, v, dt):
    """One step of refsim's stepper `integrator` from (x, v) (n, 3) on the same kernel."""
    stepper, system = get_integrator(integrator), PairSystem(masses)
    state = stepper.start(system, 0.0, x.ravel().copy(), v.ravel().copy(), dt)
    x1, v1 = stepper.output(system, dt, stepper.step(system, 0.0, state, dt), dt)
    return x1.reshape(-1, 3), v1.reshape(-1, 3)


def engine_states(engine, scene, integrator, variant, period, steps):
    """The engine's (x, v) before its first step and after each of `steps` single steps of
    period / steps, stacked (steps + 1, n, 3)."""
    sim = engine.build(scene, period / steps, integrator, variant)
    states = [sim.observe()]
    for _ in range(steps):
        sim.step(1)
        states.append(sim.observe())
    assert sim.failure is None
    sim.close()
    return np.array([o["x"] for o in states]), np.array([o["v"] for o in states])


def run(engine, scene, integrator, variant, period, steps):
    sim = engine.build(scene, period / steps, integrator, variant)
    sim.step(steps)
    assert sim.failure is None
    return sim.observe()


def return_error(engine, scene, integrator, variant, period, steps):
    """max |x(T) - x(0)|: the exact orbit returns to its start after one period."""
    return np.abs(run(engine, scene, integrator, variant, period, steps)["x"]
                  - scene.part(Particles).position).max()


def fitted_orders(errors):
    return np.log2(np.array(errors[:-1]) / np.array(errors[1:]))


def energy(obs, m):
    return 0.5 * np.sum(m * np.sum(obs["v"] ** 2, axis=1)) + potential_energy(obs["x"], m)


def angular_momentum(obs, m):
    return np.sum(m[:, None] * np.cross(obs["x"], obs["v"]), axis=0)


def energy_and_l(engine, scene, integrator, variant, steps, periods=5):
    """Step one at a time over `periods` periods of 2 pi (Kepler, a = 1, G M = 1) at
    h = 2 pi / steps: (max |dE| in each period, max |dL| over the run)."""
    m = scene.part(Particles).mass
    sim = engine.build(scene, TWO_PI / steps, integrator, variant)
    o0 = sim.observe()
    de, dl = [], []
    for _ in range(periods * steps):
        sim.step(1)
        o = sim.observe()
        de.append(abs(energy(o, m) - energy(o0, m)))
        dl.append(np.abs(angular_momentum(o, m) - angular_momentum(o0, m)).max())
    sim.close()
    return np.array(de).reshape(periods, steps).max(axis=1), max(dl)
