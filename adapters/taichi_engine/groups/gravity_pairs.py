"""taichi's n-body gravity: the scene's particles attract in all pairs (`GravityPairs`), the
model of `refsim.models.nbody_gravity` written as float64 kernels
(`refsim_adapters.taichi_engine.gravity_kernels`: the two agree to round-off at equal stepper).
Integrators: symplectic_euler, velocity_verlet, rk4, each with its time loop inside one kernel.

Claims scenes whose parts are exactly particles and a GravityPairs part, with no uniform
field (scene.gravity = 0: the kernels carry no field). Observes x, v (n, 3) and the extras
`energy` () J, `momentum` (3,), `angular_momentum` (3,), and for two bodies `runge_lenz`
(3,), computed from the observed state by the numpy model (outside the timed loop).
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup
from refsim.models.nbody_gravity import GravitySystem
from refsim.scene import Particles
from refsim.scene.gravity_pairs import GravityPairs

from ..kernel_store import observed, to_ndarray, to_taichi
from ..sim import KernelSim

INTEGRATORS = ("symplectic_euler", "velocity_verlet", "rk4")
NATIVE = {"symplectic_euler": "kernel: a = a(x) (all pairs); v += h a; x += h v",
          "velocity_verlet": "kernel: v += h/2 a; x += h v; a = a(x) (all pairs); v += h/2 a",
          "rk4": "kernel: classical RK4 on (x, v), each stage's all-pairs a(x) into scratch "
                 "arrays"}


def claims(scene) -> bool:
    return scene.part_kinds() == {"particles", "gravity_pairs"} and scene.contact is None


def supports(engine, scene, integrator):
    if integrator is not None and integrator not in INTEGRATORS:
        return (f"taichi gravity_pairs group: integrator must be one of {list(INTEGRATORS)} "
                f"(got {integrator!r})")
    if np.any(scene.gravity):
        return "taichi gravity_pairs kernels carry no uniform field (scene.gravity must be 0)"
    return None


def build(engine, scene, dt, integrator, formulation):
    if integrator not in INTEGRATORS:
        raise ValueError(f"taichi gravity integrator must be one of {list(INTEGRATORS)}, got "
                         f"{integrator!r}")
    return GravitySim(scene, dt, integrator)


class GravitySim(KernelSim):
    system = "gravity_pairs"

    def __init__(self, scene, dt, integrator):
        from .. import gravity_kernels as gk
        from .pivots import runtime_kernels
        bodies, self.pairs = scene.part(Particles), scene.part(GravityPairs)
        made = runtime_kernels()
        if (self.system, integrator) not in made:
            made[(self.system, integrator)] = gk.gravity_kernels(integrator)
        n = len(bodies)
        self.x = to_ndarray(np.array(bodies.position, float))
        self.v = to_ndarray(np.array(bodies.velocity, float))
        scratch = [to_taichi(np.zeros((n, 3))) for _ in range(5)]  # a, xs, vs, sx, sv
        pack = gk.gravity_t(mass=to_taichi(np.array(bodies.mass, float)), G=self.pairs.G,
                            eps2=self.pairs.softening ** 2)
        self.model = GravitySystem(bodies.mass, self.pairs.G, self.pairs.softening)
        super().__init__(dt, integrator, "", (self.x, self.v, *scratch, pack))

    def _observe(self):
        x, v = observed(self.x), observed(self.v)
        inv = self.model.invariants(x.reshape(-1), v.reshape(-1))
        return {"x": x, "v": v, "energy": float(inv.pop("energy")), **inv}

    def settings(self):
        base = self.base_settings()
        entry = {**base["integrator"], "native": NATIVE[self.integrator]}
        return {**base, "integrator": entry,
                "model": "all-pairs Newtonian gravity, Plummer softening "
                         "a_i = G sum_j m_j d / (|d|^2 + eps^2)^1.5",
                "G": self.pairs.G, "softening": self.pairs.softening,
                "pairs": "all pairs (no cut-off, no tree or mesh approximation)",
                "loops": "serial over bodies and pairs inside the serialized time loop",
                "damping": "none", "velocity_clamp": None}


MODEL_GROUP = ModelGroup(name="gravity_pairs", build=build, claims=claims,
                         parts=frozenset({"particles", "gravity_pairs"}),
                         features=frozenset({"gravity_pairs"}), supports=supports,
                         integrators=INTEGRATORS)
