"""Thin static plates (the Plates part, issue 28 tunnelling) in pymunk's sphere scenes.

pymunk is 2D: a plate whose centre and normal lie in pymunk's plane (a 3D scene's x-z plane,
a 2D scene's x-y plane) is its cross-section there, a static `Poly` rectangle (radius 0) of
thickness w along the normal and length 2 half_size across it, with the circles' sqrt(e) and
sqrt(mu). pymunk has no continuous detection: overlaps are found at the drifted positions
once per step. Measured on pymunk 7.3.1 (tests/engines/pymunk/test_pymunk_tunnelling.py): a
circle found overlapping with its centre past the plate's mid-plane is pushed out through the
far face (the polygon test takes the face of least penetration), so it tunnels from
v dt > w/2 + r, half the geometric (w + 2r) / dt.
"""
from __future__ import annotations

import numpy as np

from ..common.contacts import per_shape_coefficients
from .sim import PymunkSim

OFF_PLANE = ("pymunk is 2D: a plate must have its centre and normal in pymunk's plane (a 3D "
             "scene's x-z plane, a 2D scene's x-y plane)")
DETECTION_NOTE = (
    "none (pymunk has no continuous collision detection): overlaps at the drifted positions "
    "once per step; a circle whose centre is past a plate's mid-plane is pushed out through "
    "the far face (least penetration): tunnels from v dt > w/2 + r")


def plane_reason(scene, plates, normal_axis: int) -> str | None:
    """None when every plate lies across pymunk's plane, else why not."""
    if np.any(plates.center[:, normal_axis] != 0) or np.any(plates.normal[:, normal_axis] != 0):
        return OFF_PLANE
    return None


def plate_polys(pymunk, space, plates, plane, contact) -> list:
    """One static Poly rectangle per plate (its cross-section in pymunk's plane)."""
    e, mu = per_shape_coefficients(contact)
    out = []
    for c, n, w, half in zip(plates.center, plates.normal, plates.thickness, plates.half_size):
        c2, n2 = np.array(plane.to2d(c)), np.array(plane.to2d(n))
        n2 /= np.linalg.norm(n2)  # unit already, up to the plane's dropped zero component
        t2 = np.array([-n2[1], n2[0]])
        corners = [tuple(c2 + a * 0.5 * w * n2 + b * half * t2)
                   for a, b in ((1, 1), (-1, 1), (-1, -1), (1, -1))]
        poly = pymunk.Poly(space.static_body, corners, radius=0.0)
        poly.elasticity, poly.friction = e, mu
        out.append(poly)
    return out


class PlatesSim(PymunkSim):
    """The spheres group's space with the scene's plates as static rectangles."""

    def __init__(self, pymunk, scene, dt, formulation, particles, plates, **parts):
        super().__init__(pymunk, scene, dt, formulation, particles, **parts)
        self.plates = plate_polys(pymunk, self.space, plates, self.plane, scene.contact)
        self.space.add(*self.plates)

    def settings(self):
        out = super().settings()
        out["ccd"] = DETECTION_NOTE
        out["detection"] = "discrete"
        out["plate_side"] = "nearest"
        out["plate_projection"] = "none"  # position correction off: the velocity alone changes
        out["plate_side_note"] = ("an overlap found at a step's end pushes the circle out of "
                                  "the face of least penetration (through, once its centre is "
                                  "past the mid-plane); position correction off: the bounce "
                                  "starts from the overlapped position")
        out["plates"] = (f"{len(self.plates)} static Poly rectangles (radius 0): each plate's "
                         "cross-section in pymunk's plane, thickness w along the normal, "
                         "length 2 half_size; the circles' sqrt(e), sqrt(mu)")
        return out

    def close(self):
        super().close()
        self.plates = None
