"""An elastic body of P1 elements: the mesh part's elements (refsim.models.fem.elements) with
its material's law (refsim.models.fem.laws), in the body's own coordinates.

Triangles live in their plane: local coordinates are X @ basis.T (basis of
refsim.scene.meshes.mesh_plane: the x-y axes for a mesh in a z = const plane, so the local
coordinates are the world's x, y exactly), d = 2; tetrahedra use world coordinates, d = 3.
Energies in J, forces in N, node positions x (n, d) in m. A material with plasticity gets the
von Mises law of refsim.models.fem.plasticity around its elastic law; `commit(x)` stores the
plastic strain reached at x.
"""
from __future__ import annotations

import numpy as np

from .elements import Elements
from .laws import Law, law_of


class ElasticBody:
    """elements (Elements), law (Law); for triangles the plane's basis (2, 3) and offset
    (the rest plane's position along its normal)."""

    def __init__(self, elements: Elements, law: Law, basis=None, offset=None):
        self.elements, self.law = elements, law
        self.basis = None if basis is None else np.asarray(basis, float)
        self.offset = None if offset is None else np.asarray(offset, float)
        self.d = elements.d

    @classmethod
    def of(cls, mesh) -> ElasticBody:
        """The body of a TriangleMesh or TetMesh part."""
        from refsim.scene.meshes import TriangleMesh, mesh_plane
        basis = offset = None
        if isinstance(mesh, TriangleMesh):
            basis, normal = mesh_plane(mesh.vertices, mesh.triangles)
            offset = (mesh.vertices[0] @ normal) * normal
            elements = Elements(mesh.vertices @ basis.T, mesh.triangles, mesh.thickness)
            law = law_of(mesh.material, 2, mesh.plane)
        else:
            elements, law = Elements(mesh.vertices, mesh.tetrahedra), law_of(mesh.material, 3)
        if mesh.material.plasticity is not None:
            from .plasticity import VonMises
            law = VonMises(law, mesh.material.plasticity, elements.m)
        return cls(elements, law, basis, offset)

    @property
    def linear(self) -> bool:
        """Forces affine in the positions: the linear (Cauchy) law without plasticity."""
        return self.law.name == "linear" and not hasattr(self.law, "commit")

    def to_local(self, world):
        """(..., n, d) local coordinates of world points or vectors (..., n, 3)."""
        world = np.asarray(world, float)
        return world if self.basis is None else world @ self.basis.T

    def to_world(self, local, vectors=False):
        """World points (..., n, 3) of local coordinates; `vectors`: no offset."""
        if self.basis is None:
            return np.asarray(local, float)
        out = np.asarray(local, float) @ self.basis
        return out if vectors else out + self.offset

    def deformation_gradient(self, x):
        return self.elements.deformation_gradient(x)

    def stress(self, x):
        """First Piola stress per element, (m, d, d)."""
        return self.law.stress(self.deformation_gradient(x))

    def energy(self, x) -> float:
        """Elastic energy sum_e V_e Psi(F_e) (J)."""
        psi = self.law.energy_density(self.deformation_gradient(x))
        return float(self.elements.volume @ psi)

    def forces(self, x):
        """(n, d) internal elastic forces -dU/dx."""
        return self.elements.nodal_forces(self.stress(x))

    def commit(self, x) -> None:
        """Store the plastic strain of positions x (a plastic law only; no-op otherwise)."""
        if hasattr(self.law, "commit"):
            self.law.commit(self.deformation_gradient(x))

    def describe(self) -> dict:
        return {**self.law.describe(), "elements": self.elements.m, "nodes": self.elements.n,
                "element": "P1 triangle" if self.d == 2 else "P1 tetrahedron"}
