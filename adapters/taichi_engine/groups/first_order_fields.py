"""taichi's first-order particle dynamics: particles advected by an affine `VelocityField`
(rigid vortex, quadratic descent), p' = M (p - c), stepped by the float64 kernels of
`adapters.taichi_engine.first_order_kernels` (the tableaux of refsim's first-order steppers,
so the two agree to round-off). `SurfaceSampling` scenes are refused with the reason (no
taichi pair kernel for them yet). Observes x (n, 3) and v = M (x - c) (n, 3) at the observed
x, as refsim's group does.
"""
from __future__ import annotations

import time

import numpy as np

from adapters.refsim_engine.groups.first_order_fields import (FIELD_INTEGRATORS, OFFERED,
                                                              first_order_reason, model_text,
                                                              scene_reason)
from refsim.engine import ModelGroup, Sim
from refsim.integrators.first_order import get_first_order
from refsim.scene.surface_sampling import surface_sampling_of
from refsim.scene.velocity_field import velocity_field_of


def claims(scene) -> bool:
    return velocity_field_of(scene) is not None or surface_sampling_of(scene) is not None


def supports(engine, scene, integrator):
    if surface_sampling_of(scene) is not None:
        return ("taichi first-order group: surface sampling (all-pairs repulsion with "
                "projection) has no taichi kernel here; refsim runs it")
    return scene_reason(scene, "taichi") or first_order_reason(integrator, FIELD_INTEGRATORS)


class AffineFieldSim(Sim):
    """p' = M (p - c) for every particle, one kernel launch per Sim.step(n)."""

    def __init__(self, scene, dt, integrator):
        from .. import first_order_kernels as fk
        from ..kernel_store import to_ndarray
        from ..runtime import THREADS, effective_config, runtime
        rt = runtime()
        field = velocity_field_of(scene)
        self.dt, self.integrator, self.steps = float(dt), integrator, 0
        self.stepper = get_first_order(integrator)
        self.matrix, self.centre = field.matrix(), np.array(field.centre, float)
        self.model, self.threads, self.config = model_text(scene), THREADS, effective_config()
        key = ("first_order_affine", integrator)
        self.cold = key not in rt["kernels"]
        if self.cold:
            rt["kernels"][key] = fk.affine_kernel(integrator)
        self.advance = rt["kernels"][key]
        self.p = to_ndarray(np.array(scene.particles.position, float))
        self.args = (self.p, fk.mat3(self.matrix.tolist()), fk.vec3(self.centre.tolist()))
        t0 = time.perf_counter()
        self.advance(*self.args, self.dt, 0)  # compiles on first use
        rt["ti"].sync()
        self.compile_s = time.perf_counter() - t0

    def _step_impl(self, n):
        self.advance(*self.args, self.dt, int(n))

    def _observe(self):
        x = self.p.to_numpy()
        return {"x": x, "v": (x - self.centre) @ self.matrix.T}

    def settings(self):
        return {"integrator": self.stepper.describe(), "dtype": "float64",
                "threads": self.threads, **self.config, "model": self.model,
                "system": "first order p' = u(t, p) (masses and initial velocities ignored)",
                "observed_v": "u(t, p) at the observed p (numpy, from the kernel's p)",
                "time_loop": "inside one kernel per Sim.step(n): particles outermost "
                             "(parallel), each particle's steps serial",
                "implicit_euler": "(I - h M)^-1 formed once per launch (taichi 3x3 inverse)",
                "compile": "cold JIT in this build" if self.cold else
                "kernel already compiled in this process (launch time only)"}

    def close(self):
        self.args = ()


def build(engine, scene, dt, integrator, variant):
    return AffineFieldSim(scene, dt, integrator)


MODEL_GROUP = ModelGroup(name="first_order_fields", build=build, claims=claims,
                         parts=frozenset({"particles", "velocity_field", "surface_sampling"}),
                         features=frozenset({"first_order", "velocity_field",
                                             "surface_sampling"}),
                         supports=supports, integrators=OFFERED)
