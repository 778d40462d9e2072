"""Slide 001's nodal force run as printed, as a body the static solve and the steppers take in
place of the correct one (the in-house engine's FEM formulation `as_printed`).

The slide prints the force on node i of an element as f_i = Q sigma n_i: the element's stress
(P = Q sigma, the first Piola stress) times the UNIT outward normal of the face opposite node
i. The closed integral of sigma n over that face (Sifakis & Barbic 2012, sec. 4) weighs it by
the face's share w_i = t |e_i| / 2 (triangles: edge length |e_i|, thickness t) or A_i / 3
(tetrahedra: face area A_i): f_i = w_i P n_i = -V P grad phi_i, what ElasticBody computes. So
the printed force of each element node is the correct one divided by w_i, and:
- its units are N/m^2, not N: against loads in N a static solve balances them with a stress
  1/w too small (the strip of uniaxial_stretch, w = 0.0125 m^2 on its edges, stretches about
  80 times less than the closed form says);
- the forces on one element sum to P sum_i n_i, zero only where all faces have the same size:
  a uniformly stressed right triangle pushes itself along its hypotenuse's normal, so an
  irregular patch does not reproduce a linear field (the patch test fails);
- it is not the gradient of any energy: the Jacobian below is not symmetric, and the elastic
  energy the body reports is the correct law's (what the printed forces do not conserve).
Jacobian: the correct element block (-df/dx = V G^T C G) with node i's rows divided by w_i,
assembled on the same pattern (refsim.models.fem.assembly).
"""
from __future__ import annotations

import numpy as np

from .assembly import Assembler, element_stiffness
from .model import ElasticBody

FORMULATION = "as_printed"
DESCRIPTION = ("slide 001's nodal force f_i = Q sigma n_i as printed: unit face normals, without "
               "the face weight t |e_i| / 2 (A_i / 3 for tetrahedra) of the closed integral of "
               "sigma n; the correct force divided by that weight per element node")


class PrintedForceBody(ElasticBody):
    """An ElasticBody whose internal forces are the slide's printed ones."""

    @classmethod
    def of(cls, mesh) -> "PrintedForceBody":
        body = ElasticBody.of(mesh)
        return cls(body.elements, body.law, body.basis, body.offset)

    def _inverse_weights(self):
        """(m, d + 1): 1 / w_i per element node (rest shape)."""
        return 1.0 / self.elements.face_weights()

    def forces(self, x):
        """(n, d) printed nodal forces sum_e P_e n_i (unit normals), in N/m^2."""
        per_node = self.elements.element_forces(self.stress(x)) * self._inverse_weights()[..., None]
        return self.elements.gather(per_node)

    def describe(self) -> dict:
        return {**super().describe(), "nodal_force": DESCRIPTION}


class PrintedAssembler(Assembler):
    """-d(printed f)/dx: the correct element blocks with node i's d rows divided by w_i."""

    def stiffness(self, x):
        body = self.body
        tangent = body.law.tangent(body.deformation_gradient(x))
        blocks = element_stiffness(body.elements, tangent)
        rows = np.repeat(body._inverse_weights(), body.d, axis=1)  # (m, (d + 1) d)
        return self.pattern.matrix(blocks * rows[:, :, None])


def body_and_assembler(mesh, formulation: str = ""):
    """(body, assembler) of a mesh part for a formulation: "" the correct forces,
    FORMULATION the printed ones."""
    if formulation == FORMULATION:
        body = PrintedForceBody.of(mesh)
        return body, PrintedAssembler(body)
    if formulation:
        raise ValueError(f"formulation must be '' or {FORMULATION!r}, got {formulation!r}")
    body = ElasticBody.of(mesh)
    return body, Assembler(body)
