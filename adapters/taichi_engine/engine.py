"""The taichi engine: what it simulates, what it refuses (one reason each), and which Sim
builds a scene: FluidSim (sph), SphereSim (spheres), HingeSim or ParticleSim (particles)."""
from __future__ import annotations

from refsim.engine import Engine

from .runtime import import_taichi

INTEGRATORS = ("symplectic_euler", "velocity_verlet", "rk4")
VARIANTS = ("", "launch_per_step")
CONTACT_VARIANTS = VARIANTS + ("overlap_normal",)
FLUID_VARIANTS = VARIANTS + ("parallel",)


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

    def _supports(self, scene, integrator):
        if scene.fluid is not None:
            return fluid_refusal(scene, integrator)
        if any(s.other is not None for s in scene.springs):
            return ("taichi adapter: springs between two bodies are not modelled "
                    "(only springs to fixed anchors)")
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
    if scene.linear_drag > 0:
        return "taichi adapter: linear drag on SPH particles is not modelled"
    if integrator is not None and integrator != "velocity_verlet":
        return ("taichi adapter: fluid scenes step with kick-drift-kick SPH "
                "('velocity_verlet'), as refsim's")
    return None


def contact_refusal(scene, integrator):
    """Why a contact scene cannot be simulated faithfully here, or None."""
    if scene.contact is None:
        return "taichi adapter: walls need a contact model (scene.contact) for their restitution"
    if scene.joints:
        return "taichi adapter: contacts with hinged bodies are not modelled"
    if integrator is not None and integrator != "symplectic_euler":
        return ("taichi adapter: contact scenes step with symplectic_euler only (kick-drift, "
                "then impulses; a multi-stage stepper would need the impact located in time)")
    if any(b.radius <= 0 for b in scene.bodies):
        return "taichi adapter: contacts need every body to be a sphere of radius > 0"
    if scene.contact.friction > 0 and any(b.inertia <= 0 for b in scene.bodies):
        return "taichi adapter: friction needs every sphere's moment of inertia > 0"
    return None


def hinge_refusal(scene):
    """Why a scene with joints cannot be run in generalized coordinates here, or None."""
    jointed = {j.body for j in scene.joints}
    if len(jointed) != len(scene.joints) or len(jointed) != len(scene.bodies):
        return "taichi adapter: hinges need exactly one rod per body (generalized coordinates)"
    if scene.springs:
        return "taichi adapter: springs on a hinged body are not modelled"
    return None
