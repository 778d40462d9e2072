"""The sprinkler (slide 002), a ballistic emitter: particles born at a steady rate, each on its
closed-form parabola.

Scene: `Scene(parts=(Emitter(...),), gravity=(0, 0, -g))`, rate `rate` particles/s, lifetime
`lifetime` s, spawn velocity (0, 0, speed) + spread x uniform[-1, 1)^3 (seeded, the part's
`spawn_states`). Rule (refsim/models/emitter.py): particle i is born at the first step boundary
t_n >= i / rate, removed at the first one where its age >= lifetime.

Compared observable `position_error` (m): at each sample, the largest distance of a live
particle from its continuum parabola x0 + v0 a + g a^2 / 2, a = t - birth its age (birth read
from the engine, checked below). Every stepper of order >= 2 is exact for constant g: round-off
(tolerance n eps S); explicit Euler and the drift-kick symplectic Euler lag by exactly
g h a / 2, kick-drift symplectic Euler and implicit Euler lead by it (the exact discrete
parabola x0 + k h v0 + h^2 g k (k -+ 1) / 2, refsim.models.emitter.discrete_path): tolerance
g h lifetime / 2 plus round-off. Columns: `count_err_max` = max |alive - continuum count| (<=
rate h + 1: step rounding, `count_bound`), `count_ratio` = emitted / (floor(rate T) + 1),
`velocity_err_max` (m/s), `birth_delay_max` = max(birth - i / rate) (in [0, h): never early).
As printed (engine formulation "as_printed", slide 002 line ~165: k particles each step,
`velocity == g*dt` a comparison): straight lines, position error g a^2 / 2 (up to
g lifetime^2 / 2, not converging in dt), counts off by k / (rate h).
"""
from __future__ import annotations

import numpy as np

from refsim.case import EPS, Case, Param, roundoff_tolerance
from refsim.integrators.spec import spec_name
from refsim.models import emitter as em
from refsim.scene import Scene
from refsim.scene.emitter import Emitter

FIRST_ORDER = em.OLD_VELOCITY_DRIFT | em.NEW_VELOCITY_DRIFT


class SprinklerCase(Case):
    name = "sprinkler"
    description = ("particle emitter under gravity: every particle on its exact parabola, "
                   "counts = rate x time; the slide's sprinkler as printed flies straight")
    tags = ("particle_fields", "emitter", "exact")
    observable, units = "position_error", "m"
    params = {
        "rate": Param(50.0, 0.0, 1e6, "particles/s", low_inclusive=False),
        "lifetime": Param(0.5, 0.0, 1e3, "s", low_inclusive=False),
        "speed": Param(5.0, -1e3, 1e3, "mean spawn velocity along z (m/s)"),
        "spread": Param(1.0, 0.0, 1e3, "spawn velocity spread (m/s)"),
        "seed": Param(0, 0, 2 ** 31, "spawn draws"),
        "per_step": Param(1, 1, 1e4, "particles a step, as printed (k)"),
        "g": Param(9.81, 0.0, 1e3, "m/s^2"),
        "duration": Param(1.0, 0.0, 1e3, "s", low_inclusive=False),
    }
    variants = {"default": {}, "dense": {"rate": 2000.0, "lifetime": 1.0, "duration": 2.0}}
    default_variants = ("default",)
    order_meaningful = False  # exact: round-off, or the exact first-order lag g h a / 2
    samples = 50  # observations per run (each checks every live particle)

    def emitter(self, p):
        return Emitter(rate=p["rate"], lifetime=p["lifetime"], velocity=(0.0, 0.0, p["speed"]),
                       spread=p["spread"], seed=int(p["seed"]), per_step=int(p["per_step"]))

    def gravity(self, p):
        return np.array([0.0, 0.0, -p["g"]])

    def scene(self, p):
        return Scene(parts=(self.emitter(p),), gravity=tuple(self.gravity(p)))

    def t_end(self, p):
        return p["duration"]

    def dts(self, p):
        return [1e-2, 5e-3]

    def reference_dt(self, p):
        return 5e-3

    def bodies(self, p):
        return int(p["rate"] * p["lifetime"]) + 1

    def motion_scale(self, p):
        """|v0|max lifetime + g lifetime^2 / 2 (m): the longest flight."""
        top = abs(p["speed"]) + np.sqrt(3.0) * p["spread"]
        return top * p["lifetime"] + 0.5 * p["g"] * p["lifetime"] ** 2

    def observables(self, p, obs):
        ids = np.asarray(obs["id"])
        live = ids >= 0
        t = np.asarray(obs["t"], float)[:, None]
        age = t - np.where(live, obs["birth"], 0.0)
        x0, v0 = self.emitter(p).spawn_states(np.maximum(ids, 0))
        shape = ids.shape + (3,)
        g = self.gravity(p)
        x_ref = x0.reshape(shape) + v0.reshape(shape) * age[..., None] + 0.5 * g * age[
            ..., None] ** 2
        v_ref = v0.reshape(shape) + g * age[..., None]
        dx = np.where(live, np.linalg.norm(obs["x"] - x_ref, axis=-1), 0.0)
        dv = np.where(live, np.linalg.norm(obs["v"] - v_ref, axis=-1), 0.0)
        delay = np.where(live, obs["birth"] - ids / p["rate"], -np.inf)
        return {"position_error": dx.max(axis=1), "velocity_error": dv.max(axis=1),
                "alive": live.sum(axis=1).astype(float),
                "emitted": np.asarray(obs["emitted"], float),
                "birth_delay": delay.max(axis=1)}

    def reference(self, p, t):
        t = np.asarray(t, float)
        e = self.emitter(p)
        return {"position_error": np.zeros(len(t)), "velocity_error": np.zeros(len(t)),
                "alive": em.continuum_alive(e, t), "emitted": np.floor(t * p["rate"]) + 1,
                "birth_delay": np.zeros(len(t))}

    def extra_metrics(self, p, obs, observed, reference):
        return {"count_err_max": float(np.max(np.abs(observed["alive"] - reference["alive"]))),
                "count_ratio": float(observed["emitted"][-1] / reference["emitted"][-1]),
                "velocity_err_max": float(np.max(observed["velocity_error"])),
                "birth_delay_max": float(np.max(observed["birth_delay"]))}

    def state_scale(self, p):
        """S = (X + V lifetime / 2) / 2 (m): a step rounds x by eps/2 |x| <= eps/2 X (X = the
        motion scale, the farthest a particle gets from the origin) and v by eps/2 |v| <= eps/2
        V (V = |v0|max + g lifetime), which the rest of the life carries: over a life of L
        steps sum_j (L - j) h = L lifetime / 2 (to one step), so L eps S in all."""
        top = abs(p["speed"]) + np.sqrt(3.0) * p["spread"]
        speed = top + p["g"] * p["lifetime"]
        return 0.5 * (self.motion_scale(p) + 0.5 * speed * p["lifetime"]), speed

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        steps = em.life_steps(self.emitter(p), dt)
        scale, speed = self.state_scale(p)
        roundoff, roundoff_reason = roundoff_tolerance(steps, scale)
        # the reference's own evaluation x0 + v0 a + g a^2 / 2: <= 4 roundings of <= eps/2 X,
        # and the age a = t - birth rounded by eps/2 t <= eps/2 T, times the speed
        reference = EPS * (2.0 * self.motion_scale(p) + 0.5 * p["duration"] * speed)
        roundoff += reference
        roundoff_reason += (f"; n counts a life's steps, S = (X + V lifetime / 2) / 2 (see "
                            f"state_scale); plus the reference's rounding {reference:.3g} m")
        if spec_name(integrator) in FIRST_ORDER:
            lag = 0.5 * p["g"] * dt * p["lifetime"]
            return lag + roundoff, ("first order, exact discrete parabola: x_k lags or leads "
                                    "the parabola by exactly g h a / 2 at age a < lifetime, "
                                    f"<= g h lifetime / 2 = {lag:.3g} m" + roundoff_reason)
        return roundoff, ("order >= 2: exact for constant gravity (x_k = x0 + k h v0 + "
                          "g (k h)^2 / 2)" + roundoff_reason)


CASE = SprinklerCase()
