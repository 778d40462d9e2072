"""Triangle meshes with a material, for finite elements (the `TriangleMesh` part, its
`Material` and optional `Plasticity`)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._validate import (ArrayPart, _nonnegative, _positive, _set, choice, float_array,
                        index_array, zeros_or)

STRAIN_MEASURES = ("linear", "green", "corotated")
DEGENERATE_AREA = 1e-12  # a triangle with area <= this x (longest edge)^2 is degenerate


@dataclass(frozen=True)
class Plasticity:
    """Von Mises plasticity: yield_stress (Pa, >= 0) and linear isotropic hardening modulus
    (Pa, >= 0)."""

    yield_stress: float
    hardening: float = 0.0

    def __post_init__(self):
        _set(self, "yield_stress", _nonnegative("plasticity.yield_stress", self.yield_stress))
        _set(self, "hardening", _nonnegative("plasticity.hardening", self.hardening))


@dataclass(frozen=True)
class Material:
    """An isotropic elastic solid: Young's modulus E (Pa, > 0), Poisson ratio nu in (-1, 0.5),
    density (kg/m^3, > 0), the strain measure ("linear": small strain; "green": Green-Lagrange,
    St Venant-Kirchhoff; "corotated": small strain in a rotated frame) and optional
    plasticity."""

    youngs_modulus: float
    poisson_ratio: float
    density: float
    strain: str = "linear"
    plasticity: Plasticity | None = None

    def __post_init__(self):
        _set(self, "youngs_modulus", _positive("material.youngs_modulus", self.youngs_modulus))
        nu = float(self.poisson_ratio)
        if not math.isfinite(nu) or not -1.0 < nu < 0.5:
            raise ValueError(f"material.poisson_ratio must be in (-1, 0.5), got {nu}")
        _set(self, "poisson_ratio", nu)
        _set(self, "density", _positive("material.density", self.density))
        choice("material.strain", self.strain, STRAIN_MEASURES)
        if self.plasticity is not None and not isinstance(self.plasticity, Plasticity):
            raise ValueError("material.plasticity must be a Plasticity or None")

    def features(self) -> set[str]:
        return {"plasticity"} if self.plasticity is not None else set()


def triangle_areas(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def _check_degenerate(vertices: np.ndarray, triangles: np.ndarray) -> None:
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    longest = np.max([np.sum((b - a) ** 2, 1), np.sum((c - b) ** 2, 1),
                      np.sum((a - c) ** 2, 1)], axis=0)
    bad = triangle_areas(vertices, triangles) <= DEGENERATE_AREA * longest
    if np.any(bad):
        raise ValueError(f"mesh.triangles must not be degenerate (area > {DEGENERATE_AREA:g} "
                         f"x longest edge^2), triangles {np.flatnonzero(bad)[:5].tolist()} are")


@dataclass(frozen=True, eq=False)
class TriangleMesh(ArrayPart):
    """vertices (n, 3) m; triangles (m, 3) vertex indices, three distinct and of non-zero
    area each; the material; velocities (n, 3) m/s (zeros when omitted); thickness (m, > 0)
    of the sheet (mass = density x thickness x area; 1: per unit thickness)."""

    vertices: np.ndarray
    triangles: np.ndarray
    material: Material
    velocities: np.ndarray | None = None
    thickness: float = 1.0

    kind = "meshes"
    many = True  # a scene may hold several meshes

    def __post_init__(self):
        vertices = float_array("mesh.vertices", self.vertices, (None, 3))
        n = len(vertices)
        triangles = index_array("mesh.triangles", self.triangles, 3, n)
        if len(triangles) == 0:
            raise ValueError("mesh.triangles must hold at least one triangle")
        _check_degenerate(vertices, triangles)
        if not isinstance(self.material, Material):
            raise ValueError("mesh.material must be a Material")
        _set(self, "vertices", vertices)
        _set(self, "triangles", triangles)
        _set(self, "velocities", zeros_or("mesh.velocities", self.velocities, (n, 3)))
        _set(self, "thickness", _positive("mesh.thickness", self.thickness))

    def __len__(self) -> int:
        return len(self.vertices)

    def features(self) -> set[str]:
        return {"fem"} | self.material.features()
