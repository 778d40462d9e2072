"""The in-house engine's emitter group: the `Emitter` part's particles under the scene's
uniform gravity, in fixed slots (refsim/models/emitter.py: schedule, capacity, slot i mod c),
stepped by a fixed-step `refsim.integrators` stepper on the flat (3c,) slot state.

Each `step`: one stepper step of every slot (free slots hold zeros and are stepped too: a
vector operation, no branch), then the boundary's removals and births; a new particle's
stepper state is the stepper's own `start` of its spawn state, merged into the carried state
by a slot mask (so Verlet's carried acceleration, Stormer's difference and leapfrog's half
step velocity are started for it as for a fresh run). Formulations (named alternatives of one model):
"corrected" (default) and "as_printed" (slide 002: k particles a step, no acceleration).
Observables: see refsim/scene/emitter.py.
"""
from __future__ import annotations

import numpy as np

from refsim_adapters.common.particle_fields import PRINTED
from refsim.engine import ModelGroup, Sim
from refsim.integrators import get_integrator
from refsim.models import emitter as em
from refsim.models.system import ParticleSystem
from refsim.scene.emitter import FREE_SLOT_VALUE
from refsim.scene.emitter import Emitter

INTEGRATORS = ("explicit_euler", "symplectic_euler", "symplectic_euler_dk", "midpoint", "heun",
               "rk2", "rk4", "dopri5", "stormer_verlet", "velocity_verlet", "leapfrog")
class EmitterSim(Sim):
    def __init__(self, scene, dt, stepper, formulation):
        self.dt, self.stepper, self.formulation = float(dt), stepper, formulation
        self.emitter, self.gravity = scene.part(Emitter), np.asarray(scene.gravity, float)
        self.capacity = em.capacity(self.emitter, self.dt, formulation)
        self.life_steps = em.life_steps(self.emitter, self.dt)
        g = np.zeros(3) if formulation == "as_printed" else self.gravity
        self.system = ParticleSystem(np.ones(self.capacity), g)
        zeros = np.zeros(3 * self.capacity)
        self.state = stepper.start(self.system, 0.0, zeros, zeros.copy(), self.dt)
        self.ids = np.full(self.capacity, -1, dtype=np.int64)
        self._boundary(0)

    def _boundary(self, n):
        """Removals and births at boundary n: the slots become the ids alive at n."""
        alive = em.alive_ids(self.emitter, self.dt, n, self.formulation)
        ids = np.full(self.capacity, -1, dtype=np.int64)
        ids[alive % self.capacity] = alive
        born = (ids >= 0) & (ids != self.ids)
        self.ids = ids
        if not born.any():
            return
        x0, v0 = np.zeros((self.capacity, 3)), np.zeros((self.capacity, 3))
        x0[born], v0[born] = self.emitter.spawn_states(ids[born])
        fresh = self.stepper.start(self.system, n * self.dt, x0.reshape(-1), v0.reshape(-1),
                                   self.dt)
        mask = np.repeat(born, 3)
        self.state = tuple(np.where(mask, new, old) for new, old in zip(fresh, self.state))

    def _step_impl(self, n):
        for k in range(self.steps, self.steps + n):  # a loop over steps: births between them
            _, self.state = self.stepper.advance(self.system, k * self.dt, self.state,
                                                 self.dt, 1)
            self._boundary(k + 1)

    def _observe(self):
        x, v = self.stepper.output(self.system, self.time(), self.state, self.dt)
        free = self.ids < 0
        x, v = x.reshape(-1, 3).copy(), v.reshape(-1, 3).copy()
        x[free], v[free] = FREE_SLOT_VALUE, FREE_SLOT_VALUE
        births = em.birth_steps(self.emitter, self.dt, np.maximum(self.ids, 0), self.formulation)
        return {"id": self.ids.copy(), "x": x, "v": v,
                "birth": np.where(free, np.nan, births * self.dt),
                "emitted": int(em.emitted_count(self.emitter, self.dt, self.steps,
                                                self.formulation))}

    def settings(self):
        e = self.emitter
        return {"integrator": self.stepper.describe(), "dtype": "float64", "threads": 1,
                "formulation": self.formulation if self.formulation != "as_printed" else PRINTED,
                "capacity": self.capacity, "life_steps": self.life_steps,
                "rate": e.rate if self.formulation == "corrected" else e.per_step / self.dt,
                "per_step": e.per_step, "lifetime": e.lifetime, "spread": e.spread,
                "seed": e.seed, "slots": "particle i in slot i mod capacity",
                "free_slot_value": FREE_SLOT_VALUE,
                "stages": ["gravity" if self.formulation == "corrected" else "no_acceleration",
                           f"integrate:{self.stepper.name}", "remove_then_spawn"]}


def _claims(scene) -> bool:
    return scene.part(Emitter) is not None


def _supports(engine, scene, integrator):
    if integrator is not None and integrator not in INTEGRATORS:
        return (f"refsim emitter: integrator must be one of {list(INTEGRATORS)} (fixed steps:"
                f" births and removals fall on step boundaries; got {integrator!r})")
    return None


def _formulations(engine, scene):
    return em.FORMULATIONS


def _build(engine, scene, dt, integrator, formulation):
    return EmitterSim(scene, dt, get_integrator(integrator), formulation or "corrected")


MODEL_GROUP = ModelGroup(name="emitter", build=_build, claims=_claims,
                         parts=frozenset({"emitter"}), features=frozenset({"emitter", "gravity"}),
                         supports=_supports, formulations=_formulations, integrators=INTEGRATORS)
