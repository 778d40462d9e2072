"""Contact materials in the form engines take. (Wall points and normals need no translation:
`scene.part(Walls).point` / `.normal` are the (n_walls, 3) arrays every engine reads.)"""
from __future__ import annotations

import math


def per_shape_coefficients(contact) -> tuple[float, float]:
    """(sqrt(e), sqrt(mu)) for every shape, for engines that multiply the two shapes' values
    per contact (Bullet, Chipmunk): the pair's product is then the scene's e and mu to 1 ulp."""
    return math.sqrt(contact.restitution), math.sqrt(contact.friction)
