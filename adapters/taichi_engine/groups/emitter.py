"""taichi's emitter group: the `Emitter` part's particles in fixed slots under the scene's
uniform gravity, the ballistic update in the float64 kernel of
`refsim_adapters.taichi_engine.emitter_kernels`.

The schedule is refsim.models.emitter's (as refsim's group): particle i in slot i mod capacity,
born at its step boundary, removed at the first boundary where its age >= lifetime. Births and
removals happen at step boundaries only, so they are scheduled on the host: each `Sim.step(n)`
lists the births of its n boundaries (slot, boundary, spawn state from the part's
`spawn_states`, vectorised) and makes ONE launch, in which every slot is stepped (free ones
too: no branch) and each birth written into its slot after its boundary's step; the host then
sets the slot ids of the last boundary (removals only free ids: a free slot's numbers are
never observed). Formulations (engine variants) "corrected" and "as_printed" (slide 002: k
particles a step, no acceleration: the kernel gets g = 0). Observables id, x, v, birth,
emitted: see refsim/scene/emitter.py.
"""
from __future__ import annotations

import time

import numpy as np

from refsim_adapters.common.particle_fields import PRINTED
from refsim.engine import ModelGroup, Sim
from refsim.integrators import get_integrator
from refsim.models import emitter as em
from refsim.scene.emitter import FREE_SLOT_VALUE, Emitter

from ..kernel_store import arrays_setting, observed, to_taichi
from .flocking import chain_tableau

INTEGRATORS = ("symplectic_euler", "velocity_verlet", "rk4", "explicit_euler", "midpoint")


def method_of(stepper):
    """The kernel's stepper code and tableau arrays (a_next, b, stages)."""
    from .. import emitter_kernels as ek
    fixed = {"symplectic_euler": ek.SYMPLECTIC_EULER, "velocity_verlet": ek.VELOCITY_VERLET}
    if stepper.name in fixed:
        return fixed[stepper.name], (np.zeros(4), np.zeros(4), 0)
    return ek.EXPLICIT_RK, chain_tableau(stepper)


class EmitterKernelSim(Sim):
    def __init__(self, scene, dt, integrator, formulation):
        from .. import emitter_kernels as ek
        from ..runtime import runtime
        rt = runtime()
        self.dt, self.integrator, self.formulation = float(dt), integrator, formulation
        self.stepper = get_integrator(integrator)
        self.emitter = scene.part(Emitter)
        self.capacity = em.capacity(self.emitter, self.dt, formulation)
        self.life_steps = em.life_steps(self.emitter, self.dt)
        g = np.zeros(3) if formulation == "as_printed" else np.asarray(scene.gravity, float)
        self.method, (a_next, b, stages) = method_of(self.stepper)
        self.x, self.v = np.zeros((self.capacity, 3)), np.zeros((self.capacity, 3))
        self.pack = ek.ballistic_t(g=ek.vec3(*g.tolist()), rk_a=to_taichi(a_next),
                                   rk_b=to_taichi(b), stages=stages)
        self.advance = ek.advance_emitter
        self.cold = "emitter" not in rt["compiled"]
        t0 = time.perf_counter()
        self._launch(0, self._events(0))  # compiles on first use
        rt["ti"].sync()
        self.compile_s = time.perf_counter() - t0
        rt["compiled"].add("emitter")
        self.ids = self._slot_ids(0)
        born = self.ids >= 0
        self.x[born], self.v[born] = self.emitter.spawn_states(self.ids[born])

    def _slot_ids(self, n):
        """The slots' ids at boundary n (-1: free): alive id i in slot i mod capacity."""
        alive = em.alive_ids(self.emitter, self.dt, n, self.formulation)
        ids = np.full(self.capacity, -1, dtype=np.int64)
        ids[alive % self.capacity] = alive
        return ids

    def _events(self, n):
        """The births of boundaries steps + 1 .. steps + n as kernel events, by slot then
        boundary: (first (capacity + 1,), when (m,) in 1 .. n, x0 (m, 3), v0 (m, 3))."""
        e, h, form, k0 = self.emitter, self.dt, self.formulation, self.steps
        born = np.arange(em.emitted_count(e, h, k0, form), em.emitted_count(e, h, k0 + n, form))
        when = em.birth_steps(e, h, born, form) - k0
        if len(born) and (when.min() < 1 or when.max() > n):
            raise RuntimeError("emitter schedule: birth steps disagree with emitted counts")
        order = np.argsort(born % self.capacity, kind="stable")  # ids ascend: so do births
        born, when = born[order], when[order]
        first = np.searchsorted(born % self.capacity, np.arange(self.capacity + 1))
        x0, v0 = self.emitter.spawn_states(born)
        pad = max(len(born), 1)  # no zero-length arrays handed to the kernel
        return (first.astype(np.int32), np.resize(when.astype(np.int32), pad),
                np.resize(x0, (pad, 3)), np.resize(v0, (pad, 3)))

    def _launch(self, n, events):
        self.advance(self.x, self.v, self.pack, self.dt, int(n), self.method, *events)

    def _step_impl(self, n):
        self._launch(n, self._events(n))
        self.ids = self._slot_ids(self.steps + n)

    def _observe(self):
        free = self.ids < 0
        x, v = observed(self.x), observed(self.v)
        x[free], v[free] = FREE_SLOT_VALUE, FREE_SLOT_VALUE
        births = em.birth_steps(self.emitter, self.dt, np.maximum(self.ids, 0), self.formulation)
        return {"id": self.ids.copy(), "x": x, "v": v,
                "birth": np.where(free, np.nan, births * self.dt),
                "emitted": int(em.emitted_count(self.emitter, self.dt, self.steps,
                                                self.formulation))}

    def settings(self):
        from ..runtime import THREADS, effective_config
        e = self.emitter
        return {"integrator": self.stepper.describe(), "dtype": "float64", "threads": THREADS,
                **effective_config(),
                "formulation": self.formulation if self.formulation != "as_printed" else PRINTED,
                "capacity": self.capacity, "life_steps": self.life_steps,
                "rate": e.rate if self.formulation == "corrected" else e.per_step / self.dt,
                "per_step": e.per_step, "lifetime": e.lifetime, "spread": e.spread,
                "seed": e.seed, "slots": "particle i in slot i mod capacity",
                "free_slot_value": FREE_SLOT_VALUE,
                "births_removals": "scheduled on the host per Sim.step(n) (refsim's schedule "
                                   "and spawn states), written by the kernel into their slots "
                                   "at their step boundaries; removals only free the host's "
                                   "slot ids",
                "time_loop": "one launch per Sim.step(n); slots outermost in the kernel, each "
                             "slot's steps serial",
                "arrays": arrays_setting("x", "v", "each launch's birth events"),
                "kernel": "one kernel for every stepper (runtime code, tableau as arrays)",
                "compile": "cold JIT in this build" if self.cold else
                "kernel already compiled in this process (launch time only)",
                "stages": ["gravity" if self.formulation == "corrected" else "no_acceleration",
                           f"integrate:{self.stepper.name}", "remove_then_spawn"]}

    def close(self):
        self.pack = None


def claims(scene) -> bool:
    return scene.part(Emitter) is not None


def supports(engine, scene, integrator):
    if integrator is not None and integrator not in INTEGRATORS:
        return (f"taichi emitter: integrator must be one of {list(INTEGRATORS)} (fixed steps:"
                f" births and removals fall on step boundaries; got {integrator!r})")
    return None


def formulations(engine, scene):
    return em.FORMULATIONS


def build(engine, scene, dt, integrator, formulation):
    if integrator not in INTEGRATORS:
        raise ValueError(f"taichi emitter integrator must be one of {list(INTEGRATORS)}, got "
                         f"{integrator!r}")
    return EmitterKernelSim(scene, dt, integrator, formulation or "corrected")


MODEL_GROUP = ModelGroup(name="emitter", build=build, claims=claims,
                         parts=frozenset({"emitter"}), features=frozenset({"emitter", "gravity"}),
                         supports=supports, formulations=formulations, integrators=INTEGRATORS)
