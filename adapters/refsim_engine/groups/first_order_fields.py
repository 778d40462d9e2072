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

from refsim.engine import ModelGroup, Sim
from refsim.integrators import INTEGRATORS
from refsim.integrators.first_order import EXPLICIT_FIRST_ORDER, get_first_order
from refsim.models.advection import AffineField
from refsim.models.surface_sampling import SphereSampling
from refsim.scene.surface_sampling import surface_sampling_of
from refsim.scene.velocity_field import velocity_field_of

# offered on affine fields; "rk2" (Ralston) is left out of the matrix: on a linear field
# every two-stage second-order tableau has the same R(z) = 1 + z + z^2/2 as midpoint and Heun
FIELD_INTEGRATORS = ("explicit_euler", "midpoint", "heun", "rk4", "implicit_euler")
SAMPLING_INTEGRATORS = ("explicit_euler", "midpoint", "heun", "rk4")
SECOND_ORDER_ONLY = tuple(n for n in INTEGRATORS if n not in FIELD_INTEGRATORS)
OFFERED = FIELD_INTEGRATORS + SECOND_ORDER_ONLY  # the second-order ones answer `supports`


def first_order_reason(integrator: str, offered) -> str | None:
    """Why `integrator` does not run a first-order scene (None when it does)."""
    name = (integrator or "").partition(":")[0]
    if integrator is None or integrator in offered:
        return None
    if name in FIELD_INTEGRATORS:  # a first-order stepper not offered for this field
        return (f"{integrator!r} solves affine fields only (one linear solve a step): this "
                f"field is not affine in p; offered here: {list(offered)}")
    if name in SECOND_ORDER_ONLY or name in INTEGRATORS:
        return (f"first-order system p' = u(p): {integrator!r} steps second-order systems "
                f"and needs x'' = a; offered here: {list(offered)}")
    return f"first-order scenes: integrator must be one of {list(offered)}, got {integrator!r}"


def claims(scene) -> bool:
    """Particles moved by a VelocityField or sampling a SurfaceSampling surface."""
    return velocity_field_of(scene) is not None or surface_sampling_of(scene) is not None


def offered_for(scene) -> tuple:
    return SAMPLING_INTEGRATORS if surface_sampling_of(scene) is not None \
        else FIELD_INTEGRATORS


def scene_reason(scene, who: str) -> str | None:
    """Reasons a first-order scene is refused whatever the stepper (shared with taichi)."""
    if scene.particles is None or len(scene.particles) == 0:
        return f"{who} first-order group: the scene needs particles to move"
    if velocity_field_of(scene) is not None and surface_sampling_of(scene) is not None:
        return f"{who} first-order group: one of VelocityField and SurfaceSampling, not both"
    if any(scene.gravity) or scene.linear_drag > 0:
        return (f"{who} first-order group: massless particles moved by their field only "
                "(no gravity, no drag)")
    return None


def supports(engine, scene, integrator):
    return scene_reason(scene, "refsim") or first_order_reason(integrator, offered_for(scene))


def make_system(scene):
    """The first-order system of the scene (AffineField or SphereSampling)."""
    field = velocity_field_of(scene)
    if field is not None:
        return AffineField(field.matrix(), field.centre)
    part = surface_sampling_of(scene)
    return SphereSampling(part.radius, part.centre, part.sigma, part.alpha)


def model_text(scene) -> str:
    field = velocity_field_of(scene)
    if field is None:
        return ("Witkin-Heckbert: u_i = -P_i grad_{p_i} E_i, E_ij = alpha exp(-|p_i - p_j|^2 / "
                "(2 sigma^2)), sigma fixed; projected onto the sphere after every step")
    return {"rigid_vortex": "u = Omega x (p - c), as u = M (p - c), M = [Omega]_x",
            "quadratic_descent": "u = -grad E = -diag(lambda) (p - c)"}[field.field]


class FirstOrderSim(Sim):
    """p' = u(t, p) advanced by a first-order stepper (all particles, one array)."""

    def __init__(self, scene, dt, integrator):
        self.dt, self.integrator = float(dt), integrator
        self.stepper = get_first_order(integrator)
        self.system, self.model = make_system(scene), model_text(scene)
        self.p = np.array(scene.particles.position, float)
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


def build(engine, scene, dt, integrator, variant):
    return FirstOrderSim(scene, dt, integrator)


MODEL_GROUP = ModelGroup(name="first_order_fields", build=build, claims=claims,
                         parts=frozenset({"particles", "velocity_field", "surface_sampling"}),
                         features=frozenset({"first_order", "velocity_field",
                                             "surface_sampling"}),
                         supports=supports, integrators=OFFERED)
