"""taichi's first-order particle dynamics, the models of refsim's first_order_fields group as
float64 kernels stepped by the tableaux of refsim's first-order steppers (so the two agree to
round-off):
- an affine `VelocityField` (rigid vortex, quadratic descent), p' = M (p - c), by
  `refsim_adapters.taichi_engine.first_order_kernels`; observes x (n, 3) and v = M (x - c);
- Witkin-Heckbert sampling of a sphere (`SurfaceSampling`): all-pairs Gaussian repulsion,
  tangential descent, projection onto the sphere after every step, by
  `refsim_adapters.taichi_engine.sampling_kernels` (explicit Euler, midpoint, Heun, RK4: refsim's
  SAMPLING_INTEGRATORS); observes x, v = u(x) and "repulsion_energy", the last two from the
  observed x by refsim's numpy model (outside the timed loop), as refsim's group does.
"""
from __future__ import annotations

import time

import numpy as np

from refsim_adapters.common.first_order import (
    FIELD_INTEGRATORS,
    OFFERED,
    SAMPLING_INTEGRATORS,
    first_order_reason,
    make_system,
    model_text,
    scene_reason,
)
from refsim.engine import ModelGroup, Sim
from refsim.integrators.first_order import get_first_order
from refsim.scene import Particles
from refsim.scene.surface_sampling import SurfaceSampling
from refsim.scene.velocity_field import VelocityField

from ..kernel_store import arrays_setting, observed, to_ndarray, to_taichi
from ..sim import I32_MAX

SAMPLING_NATIVE = ("kernel: the tableau (a runtime array) stage by stage over all particles "
                   "(all-pairs u into a slope array per stage), p + sum b_s h k_s, projection")


def claims(scene) -> bool:
    return scene.part(VelocityField) is not None or scene.part(SurfaceSampling) is not None


def offered_for(scene) -> tuple:
    return SAMPLING_INTEGRATORS if scene.part(SurfaceSampling) is not None \
        else FIELD_INTEGRATORS


def supports(engine, scene, integrator):
    return scene_reason(scene, "taichi") or first_order_reason(integrator, offered_for(scene))


class AffineFieldSim(Sim):
    """p' = M (p - c) for every particle, one kernel launch per Sim.step(n)."""

    def __init__(self, scene, dt, integrator):
        from .. import first_order_kernels as fk
        from ..runtime import THREADS, effective_config, runtime
        rt = runtime()
        field = scene.part(VelocityField)
        self.dt, self.integrator, self.steps = float(dt), integrator, 0
        self.stepper = get_first_order(integrator)
        self.matrix, self.centre = field.matrix(), np.array(field.centre, float)
        self.model, self.threads, self.config = model_text(scene), THREADS, effective_config()
        key = ("first_order_affine", integrator)
        self.cold = key not in rt["kernels"]
        if self.cold:
            rt["kernels"][key] = fk.affine_kernel(integrator)
        self.advance = rt["kernels"][key]
        self.p = to_ndarray(np.array(scene.part(Particles).position, float))
        self.args = (self.p, fk.mat3(self.matrix.tolist()), fk.vec3(self.centre.tolist()))
        t0 = time.perf_counter()
        self.advance(*self.args, self.dt, 0)  # compiles on first use
        rt["ti"].sync()
        self.compile_s = time.perf_counter() - t0

    def _step_impl(self, n):
        self.advance(*self.args, self.dt, int(n))

    def _observe(self):
        x = observed(self.p)
        return {"x": x, "v": (x - self.centre) @ self.matrix.T}

    def settings(self):
        return {"integrator": self.stepper.describe(), "dtype": "float64",
                "threads": self.threads, **self.config, "model": self.model,
                "system": "first order p' = u(t, p) (masses and initial velocities ignored)",
                "observed_v": "u(t, p) at the observed p (numpy, from the kernel's p)",
                "time_loop": "inside one kernel per Sim.step(n): particles outermost "
                             "(parallel), each particle's steps serial",
                "implicit_euler": "(I - h M)^-1 formed once per launch (taichi 3x3 inverse)",
                "arrays": arrays_setting("p"),
                "compile": "cold JIT in this build" if self.cold else
                "kernel already compiled in this process (launch time only)"}

    def close(self):
        self.args = ()


class SphereSamplingSim(Sim):
    """Witkin-Heckbert sampling: all particles advanced n steps per kernel launch."""

    def __init__(self, scene, dt, integrator):
        from .. import sampling_kernels as sk
        from ..runtime import THREADS, effective_config, runtime
        rt = runtime()
        part = scene.part(SurfaceSampling)
        self.dt, self.integrator, self.steps = float(dt), integrator, 0
        self.stepper = get_first_order(integrator)
        self.system, self.model = make_system(scene), model_text(scene)
        self.threads, self.config = THREADS, effective_config()
        self.cold = "surface_sampling" not in rt["compiled"]
        self.advance = sk.advance
        start = self.system.project(np.array(scene.part(Particles).position, float))  # as refsim
        self.p = to_ndarray(start)
        tableau = sk.tableau_array(self.stepper.tableau)
        slopes = rt["ti"].ndarray(sk.vec3, shape=(len(self.stepper.tableau.b), len(start)))
        pack = sk.sampling_pack(part.radius, part.centre, part.sigma, part.alpha)
        self.args = (self.p, to_taichi(np.zeros_like(start)), slopes, to_taichi(tableau),
                     pack)
        t0 = time.perf_counter()
        self.advance(*self.args, self.dt, 0)  # compiles on first use
        rt["ti"].sync()
        self.compile_s = time.perf_counter() - t0
        rt["compiled"].add("surface_sampling")

    def _step_impl(self, n):
        done = 0
        while done < n:  # n is an i32 kernel argument
            chunk = min(n - done, I32_MAX)
            self.advance(*self.args, self.dt, chunk)
            done += chunk

    def _observe(self):
        x = observed(self.p)
        return {"x": x, "v": self.system.velocity(self.time(), x),
                "repulsion_energy": float(self.system.energy(x))}

    def settings(self):
        return {"integrator": {**self.stepper.describe(), "native": SAMPLING_NATIVE},
                "dtype": "float64", "threads": self.threads, **self.config,
                "model": self.model,
                "system": "first order p' = u(t, p) (masses and initial velocities ignored)",
                "observed_v": "u(t, p) at the observed p (refsim's numpy model, from the "
                              "kernel's p)",
                "projection": "p <- c + R (p - c) / |p - c| after every step (stages "
                              "unprojected), as refsim; the start projected by refsim's numpy",
                "pairs": "all pairs (no cut-off), j = i included (its term is 0), as refsim",
                "time_loop": "inside one kernel per Sim.step(n), ti.loop_config(serialize="
                             "True): each stage's loops over particles and pairs serial",
                "arrays": arrays_setting("p"),
                "kernel_args": "arrays + argpack, the tableau an ndarray, n a runtime i32 "
                               "(one kernel for every stepper and N: no recompilation)",
                "compile": "cold JIT in this build" if self.cold else
                "kernel already compiled in this process (launch time only)"}

    def close(self):
        self.args = ()


def build(engine, scene, dt, integrator, formulation):
    if scene.part(SurfaceSampling) is not None:
        return SphereSamplingSim(scene, dt, integrator)
    return AffineFieldSim(scene, dt, integrator)


MODEL_GROUP = ModelGroup(name="first_order_fields", build=build, claims=claims,
                         parts=frozenset({"particles", "velocity_field", "surface_sampling"}),
                         features=frozenset({"first_order", "velocity_field",
                                             "surface_sampling"}),
                         supports=supports, integrators=OFFERED)
