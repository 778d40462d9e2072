"""A home-grown engine as a user would write it: point masses under gravity and linear springs,
in numpy, behind refsim's `Engine`/`Sim` contract. Not part of refsim; the tolerance suite
(tests/harness/test_example_engine.py) checks it on its own physics.

Forces: uniform gravity m g, and per spring -k (|d| - L0) u - c (dv . u) u with d the vector
from the other end (a fixed anchor, or body `other`) to `body`, u = d / |d|; equal and opposite
on `other`. Steppers:
- symplectic_euler (kick-drift): v += dt a(x, v); x += dt v                  order 1
- velocity_verlet: v_half = v + dt/2 a; x += dt v_half; v = v_half + dt/2 a(x, v_half);
  with damping the closing half kick is redone once with that v (second order kept)  order 2
"""
from __future__ import annotations

import numpy as np

from refsim.engine import Engine, ModelGroup, Sim
from refsim.scene import Particles, Springs

ORDERS = {"symplectic_euler": 1, "velocity_verlet": 2}


class PointMassSim(Sim):
    def __init__(self, scene, dt, integrator):
        self.dt, self.integrator, self.steps = float(dt), integrator, 0
        bodies = scene.part(Particles)
        self.x, self.v = bodies.position.copy(), bodies.velocity.copy()
        self.mass = bodies.mass[:, None]
        self.gravity = np.asarray(scene.gravity, float)
        springs = scene.part(Springs) or Springs.of(())  # other: -1 where anchored
        self.body, self.other = springs.body, springs.other
        self.anchor = springs.anchor
        self.k = springs.stiffness[:, None]
        self.rest = springs.rest_length[:, None]
        self.c = springs.damping[:, None]
        self.damped = bool(np.any(self.c > 0))
        self.a = self.accel(self.x, self.v)

    # -- physics ------------------------------------------------------------------------------
    def spring_forces(self, x, v) -> np.ndarray:
        f = np.zeros_like(x)
        if not len(self.body):
            return f
        has_other = (self.other >= 0)[:, None]
        ends = np.maximum(self.other, 0)
        d = x[self.body] - np.where(has_other, x[ends], self.anchor)
        dv = v[self.body] - np.where(has_other, v[ends], 0.0)
        length = np.linalg.norm(d, axis=1, keepdims=True)
        u = np.divide(d, length, out=np.zeros_like(d), where=length > 0)
        fs = -self.k * (length - self.rest) * u - self.c * np.sum(dv * u, 1, keepdims=True) * u
        np.add.at(f, self.body, fs)
        np.add.at(f, self.other[self.other >= 0], -fs[self.other >= 0])
        return f

    def accel(self, x, v) -> np.ndarray:
        return self.gravity + self.spring_forces(x, v) / self.mass

    # -- steppers -----------------------------------------------------------------------------
    def symplectic_euler(self):
        self.v = self.v + self.dt * self.accel(self.x, self.v)
        self.x = self.x + self.dt * self.v

    def velocity_verlet(self):
        half = self.v + 0.5 * self.dt * self.a
        self.x = self.x + self.dt * half
        self.a = self.accel(self.x, half)
        self.v = half + 0.5 * self.dt * self.a
        if self.damped:
            self.a = self.accel(self.x, self.v)
            self.v = half + 0.5 * self.dt * self.a

    # -- the Sim contract ---------------------------------------------------------------------
    def step(self, n):
        advance = getattr(self, self.integrator)
        for _ in range(int(n)):
            advance()
        self.steps += int(n)

    def observe(self):
        return {"t": self.steps * self.dt, "x": self.x.copy(), "v": self.v.copy()}

    def settings(self):
        return {"integrator": {"name": self.integrator, "order": ORDERS[self.integrator],
                               "symplectic": True},
                "dtype": "float64", "threads": 1,
                "spring_damping": "along the spring axis, c (dv . u) u",
                "verlet_velocity_forces": "closing half kick redone once with the new v"}


def build_point_masses(engine, scene, dt, integrator, formulation):
    """Called by Engine.build after dt, formulation and support are checked."""
    return engine.sim_class(scene, dt, integrator)


class PointMassEngine(Engine):
    name = "example_point_mass"
    dims = (3,)
    integrators = tuple(ORDERS)
    sim_class = PointMassSim
    groups = (ModelGroup(name="point_masses", build=build_point_masses,
                         claims=lambda scene: scene.part(Particles) is not None,
                         parts=frozenset({"particles", "springs"}),
                         features=frozenset({"gravity", "springs"})),)

    def version(self) -> str:
        return "1.0"
