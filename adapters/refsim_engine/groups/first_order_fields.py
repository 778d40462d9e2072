"""The in-house engine's first-order particle dynamics (slide 003): particles advected by a
prescribed affine field (`VelocityField`: rigid vortex, gradient descent on a quadratic) or
sampling an implicit sphere (`SurfaceSampling`, Witkin-Heckbert), p' = u(t, p), stepped by the
first-order steppers of `refsim.integrators.first_order` (the tableaux of the second-order
ones run on p itself; NOT x'' = a).

Observes x (n, 3) (the positions p) and v (n, 3) = u(t, p) at the observed p (the tracer's
velocity, evaluated at observation: the contract requires v); sphere sampling adds
"repulsion_energy" () (sum_i E_i). Particle masses and initial velocities are ignored.
"""
from __future__ import annotations

import numpy as np

from refsim_adapters.common.first_order import (  # noqa: F401
    FIELD_INTEGRATORS,
    OFFERED,
    SAMPLING_INTEGRATORS,
    claims,
    first_order_reason,
    make_system,
    model_text,
    offered_for,
    scene_reason,
)
from refsim.engine import ModelGroup, Sim
from refsim.integrators.first_order import get_first_order
from refsim.models.surface_sampling import SphereSampling
from refsim.scene import Particles


def supports(engine, scene, integrator):
    return scene_reason(scene, "refsim") or first_order_reason(integrator, offered_for(scene))


class FirstOrderSim(Sim):
    """p' = u(t, p) advanced by a first-order stepper (all particles, one array)."""

    def __init__(self, scene, dt, integrator):
        self.dt, self.integrator = float(dt), integrator
        self.stepper = get_first_order(integrator)
        self.system, self.model = make_system(scene), model_text(scene)
        self.p = np.array(scene.part(Particles).position, float)
        project = getattr(self.system, "project", None)
        if project is not None:  # start on the surface
            self.p = project(self.p)
        self.stepper_t = 0.0

    def _step_impl(self, n):
        with np.errstate(all="ignore"):
            self.stepper_t, self.p = self.stepper.advance(self.system, self.stepper_t, self.p,
                                                          self.dt, n)

    def _observe(self):
        out = {"x": self.p.copy(), "v": self.system.velocity(self.time(), self.p)}
        if isinstance(self.system, SphereSampling):
            out["repulsion_energy"] = float(self.system.energy(self.p))
        return out

    def settings(self):
        projected = isinstance(self.system, SphereSampling)
        return {"integrator": self.stepper.describe(), "dtype": "float64", "threads": 1,
                "system": "first order p' = u(t, p) (masses and initial velocities ignored)",
                "model": self.model, "observed_v": "u(t, p) at the observed p",
                "projection": ("p <- c + R (p - c) / |p - c| after every step (stages "
                               "unprojected)") if projected else "none",
                "vectorised": "numpy over particles (and pairs for sampling)"}


def build(engine, scene, dt, integrator, formulation):
    return FirstOrderSim(scene, dt, integrator)


MODEL_GROUP = ModelGroup(name="first_order_fields", build=build, claims=claims,
                         parts=frozenset({"particles", "velocity_field", "surface_sampling"}),
                         features=frozenset({"first_order", "velocity_field",
                                             "surface_sampling"}),
                         supports=supports, integrators=OFFERED)
