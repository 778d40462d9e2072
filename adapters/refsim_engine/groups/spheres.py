"""The in-house engine's spheres group: spheres (and walls, thin plates) under a contact model,
stepped by a gravity kick and one of three contact formulations (`contacts.ContactSim`:
discrete, continuous, the slide's hard-sphere update as printed). Springs, rods and drag are
not combined with contacts: those scenes are claimed here and refused with the reason."""
from __future__ import annotations

from refsim.engine import ModelGroup
from refsim.scene import Joints, Particles, Plates, Springs, Walls

from ...common.checks import non_sphere_bodies

KINDS = frozenset({"particles", "springs", "joints", "walls", "plates"})


def claims(scene) -> bool:
    kinds = scene.part_kinds()
    return scene.contact is not None and "particles" in kinds and kinds <= KINDS


def _formulations(engine, scene):
    from ..contacts import CONTACT_FORMULATIONS
    if scene.part(Plates) is not None:
        # the slide's hard-sphere update acts on sphere pairs only: against plates it is the
        # discrete formulation again, a duplicate row that would pass as the seed formula
        return tuple(f for f in CONTACT_FORMULATIONS if f != "hard_sphere_seed")
    return CONTACT_FORMULATIONS


def _supports(engine, scene, integrator):
    if integrator not in (None, "symplectic_euler"):
        return ("refsim contact scenes step with symplectic Euler plus impulses: the contact "
                "solver defines the step")
    if scene.part(Springs) is not None or scene.part(Joints) is not None or scene.linear_drag:
        return "refsim contact scenes: springs, rods and drag are not combined with contacts"
    return non_sphere_bodies(scene, "refsim")


def _build(engine, scene, dt, integrator, formulation):
    from ..contacts import NO_WALLS, ContactSim
    walls = scene.part(Walls)
    planes = () if walls is None else (walls.point, walls.normal)
    planes = planes or (NO_WALLS, NO_WALLS)
    return ContactSim(dt, formulation, scene.part(Particles), scene.gravity, scene.contact,
                      *planes, plates=scene.part(Plates))


MODEL_GROUP = ModelGroup(
    name="spheres", claims=claims, parts=KINDS,
    features=frozenset({"gravity", "springs", "joints", "drag", "contacts", "walls",
                        "plates"}),
    supports=_supports, formulations=_formulations, build=_build)
