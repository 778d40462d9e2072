"""RefsimEngine: what the in-house engine simulates and which sim runs a scene.

Scenes with rods run in one of three formulations (engine variants): `generalized` (one angle
per rod, `hinges.HingeSim`), `kkt` (maximal coordinates, Lagrange multipliers, Baumgarte
stabilisation) and `penalty` (the rod as a stiff spring), both `particles.ParticleSim`.
Sphere scenes run `contacts.ContactSim`, fluid scenes `sph.FluidSim`.
"""
from __future__ import annotations

from refsim.engine import Engine
from refsim.integrators import INTEGRATORS, get_integrator

from ..common.checks import non_sphere_bodies, rods_per_body, springs_on_rod_bodies
from .contacts import CONTACT_VARIANTS, ContactSim
from .hinges import HingeSim
from .particles import ParticleSim
from .sph import FluidSim

JOINT_VARIANTS = ("generalized", "kkt", "penalty")


class RefsimEngine(Engine):
    name = "refsim"
    parts = frozenset({"particles", "springs", "joints", "walls", "fluid"})
    capabilities = frozenset({"gravity", "springs", "joints", "drag", "contacts", "walls",
                              "fluid"})
    dims = (2, 3)
    # every stepper but the implicit midpoint rule, which only the rigid group offers (its
    # point there: bounded L and E on a tumbling body); on the particle scenes it would add a
    # ninth of the refsim rows to the default run and show nothing Verlet's rows do not
    integrators = tuple(name for name in INTEGRATORS if name != "implicit_midpoint")
    reference = True  # the in-house reference simulator: listed and reported first

    # Baumgarte rate w = 5 w0 (w0 = sqrt(|g|/L), or 1 rad/s without gravity): a fixed physical
    # rate keeps every stepper's order (a rate tied to 1/dt drops RK4 to second order), and
    # w dt stays far inside every explicit stepper's stability region for the dts used here.
    baumgarte_ratio = 5.0
    # Penalty rod stiffness: rod frequency / pendulum frequency; the rod stretches by about
    # (w0 / w_rod)^2 L, so 100 gives a 1e-4 relative length error.
    penalty_ratio = 100.0

    def version(self) -> str:
        from refsim import __version__
        return __version__

    def variants(self, scene):
        if scene.contact is not None:
            return CONTACT_VARIANTS
        return JOINT_VARIANTS if scene.joints else ("",)

    def _supports(self, scene, integrator):
        if scene.contact is not None:
            return _contact_support(scene, integrator)
        if scene.fluid is not None and integrator not in (None, "velocity_verlet"):
            return "refsim fluid scenes step with kick-drift-kick SPH ('velocity_verlet')"
        if scene.joints:
            return _joint_support(scene)
        return None

    def _build(self, scene, dt, integrator, variant):
        if scene.contact is not None:
            return ContactSim(scene, dt, variant)
        if scene.fluid is not None:
            return FluidSim(scene, dt)
        stepper = get_integrator(integrator)
        if scene.joints and variant == "generalized":
            return HingeSim(scene, dt, stepper)
        return ParticleSim(scene, dt, stepper, variant, self)


def _contact_support(scene, integrator):
    if integrator not in (None, "symplectic_euler"):
        return ("refsim contact scenes step with symplectic Euler plus impulses: the contact "
                "solver defines the step")
    if scene.springs or scene.joints or scene.linear_drag:
        return "refsim contact scenes: springs, rods and drag are not combined with contacts"
    return non_sphere_bodies(scene, "refsim")


def _joint_support(scene):
    return (rods_per_body(scene, "refsim joints", every_body=True)
            or springs_on_rod_bodies(scene, "refsim joints"))
