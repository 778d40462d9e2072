"""Meshes with a material, for finite elements: the `TriangleMesh` part (P1 triangles in one
plane, plane stress or plane strain) and the `TetMesh` part (P1 tetrahedra), their `Material`
and optional `Plasticity`.

Both parts hold node positions (the rest shape), velocities, pinned nodes (held at their
positions) and nodal loads (N, constant external forces). Element orientation is checked here,
once: a triangle is positive when counter-clockwise about the mesh plane's normal (+z for a
mesh in a z = const plane, the y-up convention of 2D scenes; otherwise the normal is the sum
of the triangles' area vectors), a tetrahedron when (x1 - x0) . ((x2 - x0) x (x3 - x0)) > 0.
An inverted or mixed-orientation mesh is refused with the elements named: P1 elements of
opposite orientation give rest shape matrices Dm of opposite sign, and an engine that assumes
one orientation (pybullet's deformable world) explodes on them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._validate import (ArrayPart, _nonnegative, _positive, _set, choice, float_array,
                        index_array, read_only, zeros_or)

STRAIN_MEASURES = ("linear", "green", "corotated", "neo_hookean")
PLANE_MODES = ("stress", "strain")
DEGENERATE_AREA = 1e-12  # a triangle with area <= this x (longest edge)^2 is degenerate
DEGENERATE_VOLUME = 1e-12  # a tetrahedron with |volume| <= this x (longest edge)^3 is
# degenerate. A vertex out of plane by more than PLANE_TOLERANCE x the mesh's extent: not a
# plane mesh (a plane's coordinates carry round-off of ~1e-16 x extent; a bend is far above)
PLANE_TOLERANCE = 1e-9


@dataclass(frozen=True)
class Plasticity:
    """Von Mises plasticity: yield_stress (Pa, >= 0) and linear isotropic hardening modulus
    (Pa, >= 0: the slope of stress against plastic strain in uniaxial tension; 0: ideal)."""

    yield_stress: float
    hardening: float = 0.0

    def __post_init__(self):
        _set(self, "yield_stress", _nonnegative("plasticity.yield_stress", self.yield_stress))
        _set(self, "hardening", _nonnegative("plasticity.hardening", self.hardening))


@dataclass(frozen=True)
class Material:
    """An isotropic elastic solid: Young's modulus E (Pa, > 0), Poisson ratio nu in (-1, 0.5),
    density (kg/m^3, > 0), the strain measure ("linear": Cauchy small strain 1/2 (F + F^T) - I;
    "green": Green-Lagrange, St Venant-Kirchhoff; "corotated": small strain in the rotated
    frame of F = R S; "neo_hookean": the stable Neo-Hookean energy of Smith et al. 2018; the
    formulas are in refsim.models.fem.laws) and optional plasticity."""

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


def _longest_edge2(vertices: np.ndarray, cells: np.ndarray) -> np.ndarray:
    corners = [vertices[cells[:, k]] for k in range(cells.shape[1])]
    pairs = [(i, j) for i in range(len(corners)) for j in range(i + 1, len(corners))]
    return np.max([np.sum((corners[i] - corners[j]) ** 2, 1) for i, j in pairs], axis=0)


def _check_degenerate(vertices: np.ndarray, triangles: np.ndarray) -> None:
    longest = _longest_edge2(vertices, triangles)
    bad = triangle_areas(vertices, triangles) <= DEGENERATE_AREA * longest
    if np.any(bad):
        raise ValueError(f"mesh.triangles must not be degenerate (area > {DEGENERATE_AREA:g} "
                         f"x longest edge^2), triangles {np.flatnonzero(bad)[:5].tolist()} are")


def _named(bad: np.ndarray) -> str:
    idx = np.flatnonzero(bad)
    more = f" and {len(idx) - 8} more" if len(idx) > 8 else ""
    return f"{idx[:8].tolist()}{more}"


def _orientation_error(name: str, rule: str, negative: np.ndarray) -> ValueError:
    kind = "mixed orientation" if not negative.all() else "all inverted"
    return ValueError(f"{name} must be positively oriented ({rule}): elements "
                      f"{_named(negative)} are inverted ({kind}, {int(negative.sum())} of "
                      f"{len(negative)})")


def mesh_plane(vertices: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(basis (2, 3), normal (3,)) of a plane triangle mesh: the x-y axes and +z when every
    vertex has the same z (2D scenes, y-up); otherwise the normal of the summed area vectors
    and an in-plane basis whose first axis is the first triangle's first edge. Plane
    coordinates are X @ basis.T (right-handed with the normal)."""
    if np.all(vertices[:, 2] == vertices[0, 2]):
        return np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), np.array([0.0, 0.0, 1.0])
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    total = np.sum(np.cross(b - a, c - a), axis=0)
    normal = total / np.linalg.norm(total)
    edge = b[0] - a[0]
    e1 = edge - (edge @ normal) * normal
    e1 /= np.linalg.norm(e1)
    return np.array([e1, np.cross(normal, e1)]), normal


def _check_plane(vertices: np.ndarray, triangles: np.ndarray) -> None:
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    if not np.any(np.sum(np.cross(b - a, c - a), axis=0)):
        raise ValueError("mesh.triangles must be consistently oriented (their area vectors "
                         "sum to zero: a closed or folded surface, not a plane mesh)")
    _, normal = mesh_plane(vertices, triangles)
    height = (vertices - vertices[0]) @ normal
    extent = np.max(np.ptp(vertices, axis=0))
    off = np.abs(height) > PLANE_TOLERANCE * extent
    if np.any(off):
        raise ValueError(f"mesh.vertices must lie in one plane (plane stress / strain "
                         f"elements; within {PLANE_TOLERANCE:g} x extent), vertices "
                         f"{_named(off)} are off it by up to {np.max(np.abs(height)):.3g} m")
    signed = np.cross(b - a, c - a) @ normal
    if np.any(signed <= 0):
        raise _orientation_error("mesh.triangles", "counter-clockwise about the plane normal "
                                 f"{np.round(normal, 6).tolist()}", signed <= 0)


def _pinned(name: str, value, n: int) -> np.ndarray:
    idx = index_array(name, value, None, n)
    if len(np.unique(idx)) != len(idx):
        raise ValueError(f"{name} must name distinct nodes")
    return read_only(np.sort(idx))


def _common(part, n: int) -> None:
    """positions, velocities, pinned, loads and the material of a mesh part of n nodes."""
    if not isinstance(part.material, Material):
        raise ValueError("mesh.material must be a Material")
    positions = (part.vertices if part.positions is None
                 else float_array("mesh.positions", part.positions, (n, 3)))
    _set(part, "positions", read_only(np.array(positions, float)))
    _set(part, "velocities", zeros_or("mesh.velocities", part.velocities, (n, 3)))
    _set(part, "pinned", _pinned("mesh.pinned", part.pinned, n))
    _set(part, "loads", zeros_or("mesh.loads", part.loads, (n, 3)))


@dataclass(frozen=True, eq=False)
class TriangleMesh(ArrayPart):
    """vertices (n, 3) m, all in one plane; triangles (m, 3) vertex indices, three distinct,
    of non-zero area and counter-clockwise about the plane normal (module docstring); the
    material; velocities (n, 3) m/s (zeros when omitted); thickness (m, > 0) of the sheet
    (mass = density x thickness x area; 1: per unit thickness); plane "stress" (a thin sheet,
    sigma_zz = 0) or "strain" (a long prism, eps_zz = 0); pinned (p,) distinct node indices
    held fixed; loads (n, 3) N, constant nodal forces in the mesh plane; positions (n, 3) m,
    the initial configuration (the rest vertices when omitted), in the mesh plane: pinned
    nodes are held at it (an imposed boundary displacement)."""

    vertices: np.ndarray
    triangles: np.ndarray
    material: Material
    velocities: np.ndarray | None = None
    thickness: float = 1.0
    plane: str = "stress"
    pinned: np.ndarray | None = None
    loads: np.ndarray | None = None
    positions: np.ndarray | None = None

    kind = "meshes"
    many = True  # a scene may hold several meshes

    def __post_init__(self):
        vertices = float_array("mesh.vertices", self.vertices, (None, 3))
        n = len(vertices)
        triangles = index_array("mesh.triangles", self.triangles, 3, n)
        if len(triangles) == 0:
            raise ValueError("mesh.triangles must hold at least one triangle")
        _check_degenerate(vertices, triangles)
        _check_plane(vertices, triangles)
        _set(self, "vertices", vertices)
        _set(self, "triangles", triangles)
        _common(self, n)
        _set(self, "thickness", _positive("mesh.thickness", self.thickness))
        choice("mesh.plane", self.plane, PLANE_MODES)
        _, normal = mesh_plane(vertices, triangles)
        moved = np.abs((self.positions - vertices) @ normal) > PLANE_TOLERANCE * max(
            1.0, float(np.max(np.abs(vertices))))
        if np.any(moved):
            raise ValueError(f"mesh.positions must lie in the mesh plane, nodes "
                             f"{_named(moved)} are out of it")
        out = np.abs(self.loads @ normal) > PLANE_TOLERANCE * np.max(np.abs(self.loads),
                                                                     initial=0.0)
        if np.any(out):
            raise ValueError(f"mesh.loads must lie in the mesh plane (no stiffness normal to "
                             f"it), nodes {_named(out)} are loaded out of it")

    def __len__(self) -> int:
        return len(self.vertices)

    @property
    def elements(self) -> np.ndarray:
        return self.triangles

    def features(self) -> set[str]:
        return {"fem"} | self.material.features()


def tetrahedron_volumes(vertices: np.ndarray, tetrahedra: np.ndarray) -> np.ndarray:
    """Signed volumes (x1 - x0) . ((x2 - x0) x (x3 - x0)) / 6."""
    x0, x1, x2, x3 = (vertices[tetrahedra[:, k]] for k in range(4))
    return np.einsum("ij,ij->i", x1 - x0, np.cross(x2 - x0, x3 - x0)) / 6.0


def _check_tetrahedra(vertices: np.ndarray, tetrahedra: np.ndarray) -> None:
    volume = tetrahedron_volumes(vertices, tetrahedra)
    longest = _longest_edge2(vertices, tetrahedra) ** 1.5
    flat = np.abs(volume) <= DEGENERATE_VOLUME * longest
    if np.any(flat):
        raise ValueError(f"mesh.tetrahedra must not be degenerate (|volume| > "
                         f"{DEGENERATE_VOLUME:g} x longest edge^3), tetrahedra {_named(flat)} "
                         "are")
    if np.any(volume < 0):
        raise _orientation_error("mesh.tetrahedra", "(x1 - x0) . ((x2 - x0) x (x3 - x0)) > 0",
                                 volume < 0)


@dataclass(frozen=True, eq=False)
class TetMesh(ArrayPart):
    """vertices (n, 3) m; tetrahedra (m, 4) vertex indices, four distinct, of non-zero volume
    and positively oriented (module docstring); the material; velocities (n, 3) m/s (zeros when
    omitted); pinned (p,) distinct node indices held fixed; loads (n, 3) N, constant nodal
    forces; positions (n, 3) m, the initial configuration (the rest vertices when omitted):
    pinned nodes are held at it."""

    vertices: np.ndarray
    tetrahedra: np.ndarray
    material: Material
    velocities: np.ndarray | None = None
    pinned: np.ndarray | None = None
    loads: np.ndarray | None = None
    positions: np.ndarray | None = None

    kind = "meshes"
    many = True

    def __post_init__(self):
        vertices = float_array("mesh.vertices", self.vertices, (None, 3))
        n = len(vertices)
        tetrahedra = index_array("mesh.tetrahedra", self.tetrahedra, 4, n)
        if len(tetrahedra) == 0:
            raise ValueError("mesh.tetrahedra must hold at least one tetrahedron")
        _check_tetrahedra(vertices, tetrahedra)
        _set(self, "vertices", vertices)
        _set(self, "tetrahedra", tetrahedra)
        _common(self, n)

    def __len__(self) -> int:
        return len(self.vertices)

    @property
    def elements(self) -> np.ndarray:
        return self.tetrahedra

    def features(self) -> set[str]:
        return {"fem"} | self.material.features()


def single_mesh(scene):
    """The scene's one TriangleMesh or TetMesh part, None when it has none or several (what
    every engine's FEM group claims and runs)."""
    meshes = scene.parts_of(TriangleMesh) + scene.parts_of(TetMesh)
    return meshes[0] if len(meshes) == 1 else None
