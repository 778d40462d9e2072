"""pybullet's particles group: point masses without a contact model, with springs, rods (the
`Joints` part) and linear drag.

Claims a scene of `Particles` with, at most, `Springs` and `Joints` and no contact model (walls
or a contact model make it the spheres group's). Every body is its own Featherstone
`btMultiBody` (adapters/pybullet_engine/multibodies.py): a free point mass a floating base, a
body on a rod a fixed base at the anchor with one revolute link (generalized coordinates: the
rod length is exact, observed as a zero "constraint"). Springs and drag, which pybullet lacks,
are external forces applied before every step (forces.py). Stepper: Bullet's semi-implicit
Euler, refsim's `symplectic_euler` (kick-drift), which takes no parameter.
Refused: a body with two rods (a closed loop) and a rod whose body does not start on the circle
its hinge describes.
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup
from refsim.scene import Joints, Particles, Springs

from refsim_adapters.common.hinges import HingeFrames
from ..forces import ForceTerms
from ..multibodies import build_multibodies, hinge_settings, rods_mismatch
from ..runtime import import_pybullet
from ..sim import PybulletSim

PARTS = frozenset({"particles", "springs", "joints"})


def claims(scene) -> bool:
    """Particles, with springs and rods or not, and no contact model."""
    kinds = scene.part_kinds()
    return scene.contact is None and "particles" in kinds and kinds <= PARTS


def supports(engine, scene, integrator):
    if integrator is not None and integrator != "symplectic_euler":
        return f"pybullet's symplectic_euler takes no parameter, got {integrator!r}"
    return rods_mismatch(scene) if scene.part(Joints) is not None else None


def build(engine, scene, dt, integrator, formulation):
    return PybulletParticleSim(import_pybullet(), scene, dt)


MODEL_GROUP = ModelGroup(
    name="particles", build=build, claims=claims, parts=PARTS,
    features=frozenset({"gravity", "springs", "joints", "drag"}), supports=supports,
    integrators=("symplectic_euler",))


class PybulletParticleSim(PybulletSim):
    """Multibodies: free bases and bodies on rods; springs and drag as external forces."""

    def __init__(self, p, scene, dt):
        particles, springs = scene.part(Particles), scene.part(Springs)
        self.joints = scene.part(Joints)
        forces = ForceTerms(() if springs is None else springs.to_records(),
                            scene.linear_drag, len(particles))
        super().__init__(p, scene, dt, particles, forces)

    def _build_bodies(self):
        if self.joints is None:
            handles, self.hinges = build_multibodies(self.p, self.client, self.particles)
        else:
            handles, self.hinges = build_multibodies(
                self.p, self.client, self.particles, self.joints.to_records(),
                HingeFrames.from_scene(self.scene))
        self.model_stages = ("revolute_generalized",) if self.hinges else ()
        return handles

    def _observe(self):
        out = super()._observe()
        if self.joints is not None:
            out["constraint"] = np.zeros(len(self.joints))  # generalized coordinates
        return out

    def settings(self):
        out = super().settings()
        if self.hinges:
            out.update(hinge_settings())
        return out
