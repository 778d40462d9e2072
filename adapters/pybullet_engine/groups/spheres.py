"""pybullet's spheres group: spheres under a contact model, with static walls or not.

Claims a scene of `Particles` with, at most, `Springs`, `Joints` and `Walls` that has a contact
model or walls (walls without a contact model are refused here, with the reason). Each sphere is
a free `btRigidBody` with a GEOM_SPHERE shape, each wall a static body; Bullet's sequential
impulses apply Newton's restitution law with Coulomb friction at the contacts found at the
previous step's positions (discrete detection, an impulse model); the contact parameters that
make the outcome exact and the facts behind them are in adapters/pybullet_engine/contacts.py.
Springs and drag, which pybullet lacks, are external forces (forces.py). Stepper: Bullet's
semi-implicit Euler, refsim's `symplectic_euler`, which takes no parameter. Observables: x, v
and the spheres' angular velocities w (world).
Scenes with thin static plates (the Plates part): each plate a static GEOM_BOX body of collision
margin 0; formulations "" (discrete detection) and "ccd" (ccdSweptSphereRadius = r on every
sphere, allowedCcdPenetration 0: continuous detection); facts in
adapters/pybullet_engine/plates.py.
Refused: walls or plates without a contact model, bodies on rods (a rod's body is a multibody link
without a collision shape), a body of radius 0 and, with friction, a sphere without inertia.
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup
from refsim.scene import Joints, Particles, Plates, Springs, Walls

from refsim_adapters.common.checks import (non_sphere_bodies, spheres_without_inertia,
                                           walls_without_contact)
from ..contacts import CONTACT_PARAMS, build_spheres, build_walls, contact_settings
from ..forces import ForceTerms
from ..multibodies import rods_mismatch
from ..plates import FORMULATIONS, build_plates, enable_ccd, plate_settings
from ..runtime import import_pybullet
from ..sim import PybulletSim

WHO = "pybullet adapter"  # how the reasons name this engine
PARTS = frozenset({"particles", "springs", "joints", "walls", "plates"})


def claims(scene) -> bool:
    """Particles (with springs, rods, walls and plates or not) under a contact model or with
    walls or plates."""
    kinds = scene.part_kinds()
    return "particles" in kinds and kinds <= PARTS and \
        (scene.contact is not None or "walls" in kinds or "plates" in kinds)


def supports(engine, scene, integrator):
    if integrator is not None and integrator != "symplectic_euler":
        return f"pybullet's symplectic_euler takes no parameter, got {integrator!r}"
    rods = scene.part(Joints) is not None
    reason = rods_mismatch(scene) if rods else None
    if reason is not None:
        return reason
    if scene.contact is None:
        if scene.part(Plates) is not None:
            return (f"{WHO}: plates without a contact model (nothing says how spheres "
                    f"bounce off them)")
        return walls_without_contact(scene, WHO)
    if rods:
        return ("pybullet adapter: contacts are built for free spheres only (a body on a rod "
                "is a multibody link without a collision shape)")
    return (non_sphere_bodies(scene, WHO)
            or spheres_without_inertia(scene, WHO, friction_only=True, why=(
                "; Bullet reads a zero inertia as infinite (no spin), not as zero")))


def formulations(engine, scene):
    """With plates "" (discrete detection) and "ccd" (swept spheres); else ""."""
    return FORMULATIONS if scene.part(Plates) is not None else ("",)


def build(engine, scene, dt, integrator, formulation):
    return PybulletSphereSim(import_pybullet(), scene, dt, formulation)


MODEL_GROUP = ModelGroup(
    name="spheres", build=build, claims=claims, parts=PARTS,
    features=frozenset({"gravity", "springs", "joints", "drag", "contacts", "walls", "plates"}),
    supports=supports, formulations=formulations, integrators=("symplectic_euler",))


class PybulletSphereSim(PybulletSim):
    """Free rigid spheres and static walls under the contact parameters of contacts.py."""

    world_params = CONTACT_PARAMS
    model_stages = ("contacts:discrete_detection", "contacts:impulses")

    def __init__(self, p, scene, dt, formulation=""):
        particles, springs, walls = (scene.part(c) for c in (Particles, Springs, Walls))
        self.contact, self.walls_built = scene.contact, "none"
        self.plates, self.formulation, self.plate_ids = scene.part(Plates), formulation, []
        if formulation == "ccd":
            self.model_stages = ("contacts:continuous_detection", "contacts:impulses")
        self.walls = () if walls is None else walls.to_records()
        forces = ForceTerms(() if springs is None else springs.to_records(),
                            scene.linear_drag, len(particles))
        super().__init__(p, scene, dt, particles, forces)

    def _build_bodies(self):
        bodies = self.particles.to_records()
        handles = build_spheres(self.p, self.client, bodies, self.contact)
        self.walls_built = build_walls(self.p, self.client, self.walls, bodies, self.contact)
        if self.plates is not None:
            self.plate_ids = build_plates(self.p, self.client, self.plates, self.contact)
        if self.formulation == "ccd":
            enable_ccd(self.p, self.client, handles, self.particles.radius)
        return handles

    def _observe(self):
        out = super()._observe()
        out["w"] = np.array([self.p.getBaseVelocity(uid, physicsClientId=self.client)[1]
                             for uid, _ in self.handles], float)
        return out

    def settings(self):
        out = super().settings()
        out.update(contact_settings(self.contact, self.particles.inertia.tolist(),
                                    self.walls_built))
        if self.plates is not None:
            out.update(plate_settings(self.plates, self.formulation))
        return out
