"""The taichi engine: what it simulates, what it refuses (one reason each), and which Sim
builds a scene: FluidSim (sph), SphereSim (spheres), HingeSim or ParticleSim (particles)."""
from __future__ import annotations

from refsim.engine import Engine

from ..common.checks import (body_to_body_springs, linear_drag, non_sphere_bodies,
                             rods_per_body, spheres_without_inertia, springs_on_rod_bodies,
                             walls_without_contact)
from .runtime import THREADS, import_taichi

WHO = "taichi adapter"  # how the reasons name this engine

INTEGRATORS = ("symplectic_euler", "velocity_verlet", "rk4")
VARIANTS = ("", "launch_per_step")
CONTACT_VARIANTS = VARIANTS + ("overlap_normal",)
# fluids: no launch_per_step. One launch (~30 us, docs/engine_notes.md#taichi-kernel-launch-cost)
# is under 1 % of a WCSPH step (~3 ms at res20 on one thread): the formulation cannot show its
# point there, and its two reference-dt rows cost 27 s of the default run's work. The serial
# kernel and `parallel`.
FLUID_VARIANTS = ("", "parallel")


class TaichiEngine(Engine):
    name = "taichi"
    package = "taichi"
    parts = frozenset({"particles", "springs", "joints", "walls", "fluid"})
    capabilities = frozenset({"gravity", "springs", "joints", "drag", "contacts", "walls",
                              "fluid"})
    dims = (2, 3)
    integrators = INTEGRATORS

    def available(self) -> bool:
        try:
            import_taichi()
        except Exception:
            return False
        return True

    def variants(self, scene):
        if scene.fluid is not None:
            return FLUID_VARIANTS
        return CONTACT_VARIANTS if has_contacts(scene) else VARIANTS

    def matrix_formulations(self, scene):
        """Without `parallel` on fluids when taichi runs on one thread (THREADS, the default):
        it is then the serial kernel's arithmetic (bit-identical, tested) launched once per
        step, which adds no physics to the matrix and says nothing about parallel speed (30 s
        of the default run's work); `refsim bench sph` measures the threads."""
        forms = self.formulations(scene)
        if scene.fluid is not None and THREADS == 1:
            return tuple(f for f in forms if f != "parallel")
        return forms

    def _supports(self, scene, integrator):
        if scene.fluid is not None:
            return fluid_refusal(scene, integrator)
        reason = body_to_body_springs(scene, WHO, " (only springs to fixed anchors)")
        if reason:
            return reason
        if has_contacts(scene):
            return contact_refusal(scene, integrator)
        if scene.joints:
            return hinge_refusal(scene)
        return None

    def _build(self, scene, dt, integrator, variant):
        if integrator not in INTEGRATORS:  # the base lets "rk4:2" through; no order here
            raise ValueError(f"taichi integrator must be one of {list(INTEGRATORS)}, "
                             f"got {integrator!r}")
        return sim_class(scene)(scene, dt, integrator, variant)


def sim_class(scene):
    """The Sim that runs a supported scene."""
    if scene.fluid is not None:
        from .sph import FluidSim
        return FluidSim
    if has_contacts(scene):
        from .spheres import SphereSim
        return SphereSim
    from .particles import HingeSim, ParticleSim
    return HingeSim if scene.joints else ParticleSim


def has_contacts(scene) -> bool:
    return bool({"contacts", "walls"} & scene.features())


def fluid_refusal(scene, integrator):
    """Why a fluid scene cannot be simulated faithfully here, or None."""
    if scene.bodies or scene.springs or scene.joints or scene.contact is not None:
        return ("taichi adapter: a fluid scene holds the fluid and its tank only (bodies, "
                "springs, joints or contacts with SPH are not modelled)")
    reason = linear_drag(scene, WHO, "SPH particles")
    if reason:
        return reason
    if integrator is not None and integrator != "velocity_verlet":
        return ("taichi adapter: fluid scenes step with kick-drift-kick SPH "
                "('velocity_verlet'), as refsim's")
    return None


def contact_refusal(scene, integrator):
    """Why a contact scene cannot be simulated faithfully here, or None."""
    if scene.contact is None:
        return walls_without_contact(scene, WHO, " for their restitution")
    if scene.joints:
        return "taichi adapter: contacts with hinged bodies are not modelled"
    if integrator is not None and integrator != "symplectic_euler":
        return ("taichi adapter: contact scenes step with symplectic_euler only (kick-drift, "
                "then impulses; a multi-stage stepper would need the impact located in time)")
    return (non_sphere_bodies(scene, WHO)
            or spheres_without_inertia(scene, WHO, friction_only=True))


def hinge_refusal(scene):
    """Why a scene with joints cannot be run in generalized coordinates here, or None."""
    return (rods_per_body(scene, WHO, every_body=True, why=" (generalized coordinates)")
            or springs_on_rod_bodies(scene, WHO))
