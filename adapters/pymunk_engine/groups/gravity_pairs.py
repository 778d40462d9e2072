"""pymunk's n-body gravity: planar scenes whose parts are exactly `Particles` + `GravityPairs`.

pymunk is 2D: a scene is taken when every motion stays in the x-y plane (`stays_in_plane(2)`:
z = 0 positions, velocities and gravity; refsim (x, y) -> pymunk (x, y), observed z = 0) or, for
a 3D scene, in the x-z plane (adapters/pymunk_engine/plane.py); else the reason "pymunk is 2D".
Each particle is a `pymunk.Body(m, inf)` (a point mass: no rotation), no shapes, space damping
1.0 (none), gravity the scene's, 10 iterations (nothing to iterate on: no constraints).

Force: pymunk has no pair forces. Each body's `velocity_func` adds the pair acceleration
(refsim/models/nbody_gravity.py `pair_accelerations`, softening included) to gravity and calls
pymunk's own `Body.update_velocity` (v = v damping^h + h (g + a)). cpSpaceStep moves EVERY
body's position first (position_func: x += h v) and only then calls the velocity functions, so
the accelerations are computed once per step, in numpy for all bodies, by the first
velocity_func of the step, from the drifted positions x_{k+1}; the others read them. The step is
then x_{k+1} = x_k + h v_k; v_{k+1} = v_k + h a(x_{k+1}): refsim's symplectic_euler_dk, pymunk's
own drift-kick, the force frozen over the kick as in pymunk's semi-implicit Euler. (Computing
a(x_k) before space.step would pair the drift with the OLD positions' force: explicit Euler,
whose energy grows.) Measured (pymunk 7.3.1): bit for bit with refsim's symplectic_euler_dk.
Cost: one space.step per step plus n Python velocity_func calls and n position reads per step.
"""
from __future__ import annotations

import math

import numpy as np

from refsim.engine import ModelGroup, Sim
from refsim.models.nbody_gravity import pair_accelerations
from refsim.scene import Particles
from refsim.scene.gravity_pairs import GravityPairs

from ..plane import Plane
from ..settings import NATIVE_STEP
from ..space import ITERATIONS

COST_NOTE = ("pair force computed in numpy and applied through velocity_func with one Python "
             "call per step (space.step) plus one per body (its velocity_func, and its position "
             "read): that is this engine's real cost in this use")


def claims(scene) -> bool:
    return scene.part_kinds() == {"particles", "gravity_pairs"}


def scene_plane(scene) -> Plane | None:
    """The mapping onto pymunk's plane: x-y (Plane(2)) or a 3D scene's x-z, else None."""
    if scene.stays_in_plane(2):
        return Plane(2)
    if scene.dim == 3 and scene.stays_in_xz_plane():
        return Plane(3)
    return None


def supports(engine, scene, integrator):
    if scene_plane(scene) is None:
        return ("pymunk is 2D: an n-body gravity scene must keep every position, velocity and "
                "the gravity in the x-y plane (z = 0), or a 3D scene's in the x-z plane")
    return None


def build(engine, scene, dt, integrator, formulation):
    import pymunk  # lazily: refsim works without pymunk installed
    return PymunkGravitySim(pymunk, scene, dt)


MODEL_GROUP = ModelGroup(
    name="gravity_pairs", build=build, claims=claims,
    parts=frozenset({"particles", "gravity_pairs"}),
    features=frozenset({"gravity_pairs", "gravity"}), supports=supports,
    formulations=lambda engine, scene: ("",), integrators=("symplectic_euler_dk",))


class PymunkGravitySim(Sim):
    """One pymunk Body per particle, pushed by its velocity_func; stepped by space.step."""

    def __init__(self, pymunk, scene, dt):
        self.scene, self.dt, self.steps = scene, dt, 0
        self.plane = plane = scene_plane(scene)
        part, particles = scene.part(GravityPairs), scene.part(Particles)
        self.G, self.softening = part.G, part.softening
        self.masses = np.array(particles.mass)
        self.space = space = pymunk.Space(threaded=False)
        space.iterations, space.damping = ITERATIONS, 1.0
        space.gravity = plane.to2d(scene.gravity)
        self.bodies = []
        rows = zip(particles.mass, particles.position, particles.velocity)
        for i, (mass, position, velocity) in enumerate(rows):  # one pymunk body per particle
            body = pymunk.Body(float(mass), math.inf)
            body.position, body.velocity = plane.to2d(position), plane.to2d(velocity)
            body.velocity_func = self._velocity_func(pymunk.Body.update_velocity, i)
            self.bodies.append(body)
        space.add(*self.bodies)
        self._x3 = np.zeros((len(self.bodies), 3))  # the plane's positions as 3-vectors
        self._accel = None  # (n, 2) of the current step, None until its first velocity_func

    def _velocity_func(self, update_velocity, index):
        def kick(body, gravity, damping, dt):  # called by cpSpaceStep after every drift
            if self._accel is None:
                self._accel = self._plane_accelerations()
            ax, ay = self._accel[index]
            update_velocity(body, (gravity[0] + ax, gravity[1] + ay), damping, dt)
        return kick

    def _plane_accelerations(self) -> list:
        """a(x) at the bodies' current (drifted) positions, as (ax, ay) per body."""
        i, k = self.plane.axes
        self._x3[:, [i, k]] = [tuple(b.position) for b in self.bodies]
        a = pair_accelerations(self._x3, self.masses, self.G, self.softening)
        return a[:, [i, k]].tolist()

    def _step_impl(self, n):
        space_step, dt = self.space.step, self.dt
        for _ in range(n):  # pymunk has no multi-step call
            self._accel = None  # the next velocity_func computes this step's forces
            space_step(dt)

    def _observe(self):
        nb, (i, k) = len(self.bodies), self.plane.axes
        x, v = np.zeros((nb, 3)), np.zeros((nb, 3))
        x[:, [i, k]] = [tuple(b.position) for b in self.bodies]
        v[:, [i, k]] = [tuple(b.velocity) for b in self.bodies]
        return {"x": x, "v": v}

    def settings(self):
        i, k = self.plane.axes
        return {
            "integrator": {"name": "symplectic_euler_dk", "order": 1,
                           "family": "symplectic Euler", "explicit": True, "symplectic": True,
                           "native": NATIVE_STEP, "force_frozen_over_step": True,
                           "note": "drift with the old velocity, then the kick with a(x_{k+1}) "
                                   "computed once per step from the drifted positions"},
            "dtype": "float64", "threads": 1,
            "plane": f"refsim ({'xyz'[i]}, {'xyz'[k]}) -> pymunk (x, y); observed "
                     f"{'xyz'[self.plane.normal_axis]} = 0",
            "space": {"iterations": self.space.iterations, "damping": self.space.damping,
                      "damping_meaning": "1.0 = no damping", "gravity": list(self.space.gravity),
                      "threaded": self.space.threaded},
            "bodies": {"count": len(self.bodies), "mass": [b.mass for b in self.bodies],
                       "moment": "inf (point masses: no rotation)", "shapes": "none"},
            "force_method": "velocity_func per body: pymunk.Body.update_velocity(body, g + a, "
                            "damping, dt), a computed in numpy by the step's first velocity_func",
            "python_per_step": COST_NOTE,
            "pair_force": {"G": self.G, "softening": self.softening, "pairs": "all",
                           "kernel": "refsim.models.nbody_gravity.pair_accelerations (numpy)"},
        }

    def close(self):
        self.space = self.bodies = None
