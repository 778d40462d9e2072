"""Contact scene data in the form engines take: wall arrays and per-shape coefficients."""
from __future__ import annotations

import math

import numpy as np


def wall_arrays(walls) -> tuple[np.ndarray, np.ndarray]:
    """(points, normals), each (n_walls, 3) float64; (0, 3) without walls. The normals are the
    scene's unit normals pointing into free space."""
    points = np.array([wall.point for wall in walls]).reshape(-1, 3)
    normals = np.array([wall.normal for wall in walls]).reshape(-1, 3)
    return points, normals


def per_shape_coefficients(contact) -> tuple[float, float]:
    """(sqrt(e), sqrt(mu)) for every shape, for engines that multiply the two shapes' values
    per contact (Bullet, Chipmunk): the pair's product is then the scene's e and mu to 1 ulp."""
    return math.sqrt(contact.restitution), math.sqrt(contact.friction)
