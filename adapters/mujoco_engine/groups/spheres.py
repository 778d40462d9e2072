"""MuJoCo's sphere group: free spheres under a contact model (scene.contact), with walls or not,
and gravity (adapters/mujoco_engine/spheres.py holds the model: free joints, sphere and plane
geoms, soft contacts whose damping is calibrated to the restitution asked for).

The group claims the scenes of moving particles with a contact model or walls (walls without a
contact model are refused with the reason), without grids and other than the exact gravity-pairs
scene. Formulations (contact scenes): "" (a spring-dashpot per contact, impedance d = 1e-4) and
"coupled" (MuJoCo's constraint regime, d = 0.9999). `discrete` is refused with contacts
(backward Euler on the contact spring dissipates).

Scenes with thin static plates (the Plates part, adapters/mujoco_engine/plates.py): each plate a
box geom; formulations "" (discrete detection, d = 1e-4) and "speculative" (MuJoCo's
speculative contacts: continuous detection); plates without a contact model are refused."""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup
from refsim.scene import Joints, Particles, Plates, Springs, Walls

from .particles import particle_scene

WHO = "mujoco adapter"  # how the reasons name this engine
DISCRETE_CONTACT_REASON = (
    "mujoco discrete integrates the contact spring with backward Euler, which dissipates: "
    "e = 0.65 measured at zero damping for a 10-step contact, so larger e cannot be asked of it")


def claims(scene) -> bool:
    return particle_scene(scene) and (scene.contact is not None or
                                      scene.part(Walls) is not None or
                                      scene.part(Plates) is not None)


def refusal(scene) -> str | None:
    """Why the scene's spheres cannot be free MuJoCo bodies with soft contacts, or None."""
    from refsim_adapters.common.checks import (linear_drag, non_sphere_bodies,
                                               spheres_without_inertia, walls_without_contact)

    from ..contact_params import MAX_FRICTION_SPHERES
    if scene.contact is None:
        if scene.part(Plates) is not None:
            return (f"{WHO}: plates without a contact model (nothing says how spheres "
                    f"bounce off them)")
        return walls_without_contact(scene, WHO)
    if scene.part(Springs) is not None or scene.part(Joints) is not None:
        return ("mujoco adapter: springs and rods are not combined with contacts (every "
                "sphere is a free body)")
    reason = (linear_drag(scene, WHO, "spheres",
                          " (damping on a free joint would also damp the spin)")
              or non_sphere_bodies(scene, WHO)
              or spheres_without_inertia(scene, WHO, why=(
                  "; the adapter never lets MuJoCo derive one from the geom")))
    if reason:
        return reason
    if scene.contact.friction > 0 and len(scene.part(Particles)) > MAX_FRICTION_SPHERES:
        return (f"mujoco adapter: friction is modelled for at most {MAX_FRICTION_SPHERES} "
                f"spheres (its damping, solreffriction, is set only on explicit contact "
                f"pairs, O(n^2) of them)")
    return None


def supports(engine, scene, integrator):
    """The scene's reason, then the discrete-with-contacts one."""
    from ..methods import CONTACT_METHODS
    reason = refusal(scene)
    if reason:
        return reason
    if scene.contact is not None and integrator is not None and \
            integrator not in CONTACT_METHODS:
        return DISCRETE_CONTACT_REASON
    return None


def formulations(engine, scene):
    """Contact scenes: "" (spring-dashpot per contact, d = 1e-4) and "coupled" (MuJoCo's
    constraint regime, d = 0.9999); with plates "" and "speculative" (continuous detection);
    walls without a contact model (refused): ""."""
    from ..contact_params import IMPEDANCE
    from ..plates import FORMULATIONS
    if scene.contact is None:
        return ("",)
    return FORMULATIONS if scene.part(Plates) is not None else tuple(IMPEDANCE)


def build(engine, scene, dt, integrator, formulation):
    from ..sim import MujocoSim
    from ..spheres import ContactSetup, sphere_plan
    reason = refusal(scene)
    if reason:
        raise ValueError(reason)
    bodies, walls = scene.part(Particles).to_records(), scene.part(Walls)
    points, normals = ((np.zeros((0, 3)), np.zeros((0, 3))) if walls is None
                       else (walls.point, walls.normal))
    plates = scene.part(Plates)

    def contact():
        if plates is None:
            return ContactSetup.make(scene.contact, len(bodies), points, normals, dt,
                                     integrator, formulation)
        from ..plates import PlateContactSetup
        base = ContactSetup.make(scene.contact, len(bodies), points, normals, dt, integrator, "")
        return PlateContactSetup.with_plates(base, plates, formulation)
    return MujocoSim(scene, [sphere_plan(i, b) for i, b in enumerate(bodies)], dt, integrator,
                     contact=contact)


# springs, joints and drag are taken only to be refused with the reason (a free sphere's joint)
MODEL_GROUP = ModelGroup(
    name="spheres", build=build, claims=claims,
    parts=frozenset({"particles", "springs", "joints", "walls", "plates"}),
    features=frozenset({"gravity", "springs", "joints", "drag", "contacts", "walls", "plates"}),
    supports=supports, formulations=formulations)
