"""The scene refusals several engines share. Each check returns None when the scene passes, else
the one-sentence reason `Engine.supports` gives: "<who>: <what>[<why>]", where `who` names the
engine as its messages do ("pybullet adapter", "taichi adapter", "refsim joints" ...) and `why`
is the engine's own explanation, appended as given. The caller decides when a check applies
(e.g. only to contact scenes)."""
from __future__ import annotations

import numpy as np

from refsim.scene import Joints, Particles, Springs, Walls

_NONE = np.zeros(0, dtype=np.int64)


def _rod_bodies(scene) -> np.ndarray:
    joints = scene.part(Joints)
    return _NONE if joints is None else joints.body


def walls_without_contact(scene, who: str, why: str = "") -> str | None:
    """Walls with nothing to say how bodies bounce off them (no scene.contact)."""
    if scene.part(Walls) is not None and scene.contact is None:
        return f"{who}: walls need a contact model (scene.contact){why}"
    return None


def non_sphere_bodies(scene, who: str, why: str = "") -> str | None:
    """A contact scene's body with radius 0 (a point mass cannot collide)."""
    radii = scene.part(Particles).radius
    flat = np.flatnonzero(radii <= 0)
    if flat.size:
        return (f"{who}: contacts need every body to be a sphere of radius > 0 (body "
                f"{flat[0]} has radius {radii[flat[0]]:g}){why}")
    return None


def spheres_without_inertia(scene, who: str, friction_only: bool = False,
                            why: str = "") -> str | None:
    """A sphere with moment of inertia 0: refused always, or only when the contact model has
    friction (`friction_only`: without friction nothing makes a sphere spin)."""
    if friction_only and not scene.contact.friction > 0:
        return None
    inertias = scene.part(Particles).inertia
    flat = np.flatnonzero(inertias <= 0)
    if flat.size:
        needs = "friction needs" if friction_only else "contacts need"
        return (f"{who}: {needs} every sphere's moment of inertia > 0 (body {flat[0]} has "
                f"{inertias[flat[0]]:g}){why}")
    return None


def rods_per_body(scene, who: str, every_body: bool = False, why: str = "") -> str | None:
    """A body carrying two rods; with `every_body`, also a body carrying none."""
    rodded = _rod_bodies(scene)
    distinct = np.unique(rodded)
    if len(distinct) != len(rodded) or (every_body and len(distinct) != len(scene.part(Particles))):
        return f"{who}: {'exactly ' if every_body else ''}one rod per body{why}"
    return None


def body_to_body_springs(scene, who: str, why: str = "") -> str | None:
    """A spring between two bodies (the engine models springs to fixed anchors only)."""
    springs = scene.part(Springs)
    if springs is not None and np.any(springs.other >= 0):  # -1: the spring ends at its anchor
        return f"{who}: springs between two bodies are not modelled{why}"
    return None


def springs_on_rod_bodies(scene, who: str, why: str = "") -> str | None:
    """A spring with an end on a body that also carries a rod."""
    springs, rodded = scene.part(Springs), _rod_bodies(scene)
    if springs is not None and np.any(np.isin(springs.body, rodded) | np.isin(springs.other, rodded)):
        return f"{who}: springs on a rod's body are not modelled{why}"
    return None


def linear_drag(scene, who: str, on: str, why: str = "") -> str | None:
    """Linear drag the engine cannot apply to `on` (e.g. "spheres", "SPH particles")."""
    if scene.linear_drag > 0:
        return f"{who}: linear drag on {on} is not modelled{why}"
    return None
