"""taichi's Lennard-Jones group: particles under the pair forces of a LennardJones part, as the
float64 kernels of `refsim_adapters.taichi_engine.lj_kernels` (refsim.models.lennard_jones's
model: a grid rebuilt per force evaluation when the cut-off is finite, all pairs when it is inf; open or
periodic; 2D in the plane z = 0 or 3D). Integrators: velocity Verlet, symplectic Euler (kick
then drift), RK4, explicit Euler, the time loop inside one kernel.

Observes x (n, 3) (unwrapped, as refsim's group), v (n, 3) and `momentum` (3,) sum m v.
"""
from __future__ import annotations

import math

import numpy as np

from refsim_adapters.common.particle_fields import supports_scene
from refsim.engine import ModelGroup
from refsim.scene import Particles
from refsim.scene.lennard_jones import LennardJones

from ..kernel_store import arrays_setting, observed, to_ndarray, to_taichi
from ..runtime import THREADS, effective_config
from ..sim import KernelSim

INTEGRATORS = ("velocity_verlet", "symplectic_euler", "rk4", "explicit_euler")
CELLS_PER_PARTICLE = 4  # grid arrays hold 4 n + 64 cells (open cells grow to fit)
NATIVE = {"velocity_verlet": "kernel: v += h/2 a; x += h v; a = a(x); v += h/2 a (a carried)",
          "symplectic_euler": "kernel: v += h a(x); x += h v (kick then drift)",
          "explicit_euler": "kernel: x += h v; v += h a(x) (both from the old state)",
          "rk4": "kernel: classical 4-stage Runge-Kutta on (x, v), b-weighted stage sums"}


class LennardJonesSim(KernelSim):
    """x, v as (n, 3) numpy arrays (vec3 rows); the part's parameters, stage arrays and grid
    in the `lj_t` argpack; kernels made once per process and stepper."""

    system = "lennard_jones"

    def __init__(self, scene, dt, integrator):
        from .. import lj_kernels as lk
        from ..runtime import runtime
        made = runtime()["kernels"]
        if (self.system, integrator) not in made:
            made[(self.system, integrator)] = lk.lj_kernels(integrator)
        self.scene, self.part = scene, scene.part(LennardJones)
        particles = scene.part(Particles)
        self.masses = np.asarray(particles.mass, float)
        n = len(self.masses)
        self.x = to_ndarray(np.array(particles.position, float))
        self.v = to_ndarray(np.array(particles.velocity, float))
        self.pack = lk.lj_t(**self._parameters(lk.vec3), **self._arrays(n))
        super().__init__(dt, integrator, "", (self.x, self.v, self.pack))

    def _parameters(self, vec3) -> dict:
        part = self.part
        box = list(part.box) + [1.0] * (3 - len(part.box)) if part.box else [1.0, 1.0, 1.0]
        finite = math.isfinite(part.cutoff)  # the shift moves U only, not the force
        return dict(eps=part.epsilon, sigma=part.sigma,
                    cutoff=part.cutoff if finite else 1e308, all_pairs=int(not finite),
                    periodic=int(part.box is not None),
                    dim=self.scene.dim, box=vec3(*box))

    def _arrays(self, n) -> dict:
        cells = CELLS_PER_PARTICLE * n + 64
        self.nd = {name: to_taichi(np.zeros((n, 3))) for name in ("acc", "xs", "vs", "sx",
                                                                   "sv")}
        self.nd.update(inv_mass=to_taichi(1.0 / self.masses),
                       cell_start=to_taichi(np.zeros(cells, np.int32)),
                       cell_end=to_taichi(np.zeros(cells, np.int32)),
                       cell_of=to_taichi(np.zeros(n, np.int32)),
                       order=to_taichi(np.zeros(n, np.int32)),
                       grid=to_taichi(np.zeros(6)), dims=to_taichi(np.zeros(3, np.int32)))
        return self.nd

    def _observe(self):
        x, v = observed(self.x), observed(self.v)
        return {"x": x, "v": v, "momentum": np.sum(self.masses[:, None] * v, axis=0)}

    def settings(self):
        part = self.part
        return {"integrator": {**self.stepper.describe(), "native": NATIVE[self.integrator]},
                "dtype": "float64", "threads": THREADS, **effective_config(),
                "time_loop": "time loop inside one kernel, ti.loop_config(serialize=True)",
                "arrays": arrays_setting("x", "v"),
                "compile": "cold JIT in this build" if self.cold else
                "kernels already compiled in this process (launch time only)",
                "per_step_python_call": "none (one launch per Sim.step(n) call)",
                "epsilon": part.epsilon, "sigma": part.sigma,
                "cutoff": part.cutoff if math.isfinite(part.cutoff) else "inf",
                "shift": part.shift, "box": list(part.box) if part.box else None,
                "dim": self.scene.dim,
                "pair_search": ("all pairs (no cut-off), gathered per particle"
                                if math.isinf(part.cutoff) else
                                "grid rebuilt per force evaluation (serial counting sort, "
                                "cells >= cutoff), 27 neighbour cells gathered per particle "
                                "(no atomics)" + (", minimum image" if part.box else ""))}


def claims(scene) -> bool:
    """Particles and a LennardJones part, nothing else."""
    return scene.part_kinds() == {"particles", "lennard_jones"} and scene.contact is None


def supports(engine, scene, integrator):
    return supports_scene(scene, "taichi")


def build(engine, scene, dt, integrator, formulation):
    return LennardJonesSim(scene, dt, integrator)


MODEL_GROUP = ModelGroup(name="lennard_jones", build=build, claims=claims,
                         parts=frozenset({"particles", "lennard_jones"}),
                         features=frozenset({"lennard_jones"}), supports=supports,
                         integrators=INTEGRATORS)
