"""Scene -> one BodyPlan per body: the single source of the adapter's `supports` reasons."""
from __future__ import annotations

from .body_plan import BodyPlan
from .point_masses import point_mass_plans
from .spheres import sphere_plans


def plan_scene(scene) -> list[BodyPlan]:
    """One plan per body; ValueError with a one-sentence reason when it cannot be faithful."""
    if scene.contact is not None or scene.walls:
        return sphere_plans(scene)
    return point_mass_plans(scene)
