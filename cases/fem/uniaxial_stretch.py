"""Uniaxial stretch of a strip (slide 001's strain measures against their closed forms): a
plane-stress strip L x H (thickness t), Poisson ratio 0, its left edge clamped, a total force F
along x on its right edge (consistent nodal loads of a uniform traction: F / ny per edge node,
half at the two corners). With nu = 0 every law keeps the strip's height (no lateral stress at
F = diag(lambda, 1)), so x = (lambda X, Y) is an exact equilibrium of the P1 mesh: a constant F
in every element, the clamped edge at X = 0 unmoved, and the edge loads balancing P11 t H.
The stretch lambda solves P11(lambda) t H = F per law:
    linear (Cauchy, small strain) and corotated   E (lambda - 1)            -> 1 + F / (E t H)
    green (St Venant-Kirchhoff)                   E lambda (lambda^2 - 1) / 2
(MuJoCo 4's flex, StVK on P1 triangles, settles two triangles with E = 1000, t = 0.1, F = 10 at
lambda = 1.0880339, the StVK root.) Neo-Hookean contracts laterally even at nu = 0 (its
stretch is not homogeneous under a clamped edge): not a variant here.
Error: ||x - (lambda X, Y)||_2 over every node (m), solved statically (meta solve = static);
the bound is the static solve's (cases/fem/_static.py).
"""
from __future__ import annotations

import numpy as np

from refsim.case import Param
from refsim.models.fem.meshes import rectangle_triangles
from refsim.scene import Material, Scene, TriangleMesh

from ._static import StaticCase


def stretch(strain: str, force: float, youngs_modulus: float, area: float) -> float:
    """lambda with P11(lambda) area = force (closed forms above; the StVK cubic's real root
    above 1 by numpy's companion-matrix roots, polished by two Newton steps)."""
    s = force / (youngs_modulus * area)
    if strain in ("linear", "corotated"):
        return 1.0 + s
    lam = max(r.real for r in np.roots([0.5, 0.0, -0.5, -s]) if abs(r.imag) < 1e-9)
    for _ in range(2):
        lam -= (0.5 * lam * (lam * lam - 1.0) - s) / (1.5 * lam * lam - 0.5)
    return float(lam)


class UniaxialStretch(StaticCase):
    name = "uniaxial_stretch"
    description = ("plane-stress strip, nu = 0, clamped left edge, force F on the right edge: "
                   "x = (lambda X, Y), lambda from each law's closed form")
    tags = ("fem", "static", "closed form")
    params = {
        "strain": Param("corotated", choices=("linear", "green", "corotated")),
        "force": Param(2.0, 0.0, 1e9, "total force F on the right edge (N)"),
        "youngs_modulus": Param(1000.0, 1e-6, 1e12, "E (Pa)", low_inclusive=False),
        "length": Param(1.0, 1e-3, 1e3, "L (m)"),
        "height": Param(0.2, 1e-3, 1e3, "H (m)"),
        "thickness": Param(0.1, 1e-4, 10.0, "t (m)"),
        "cells": Param(4, 1, 64, "cells along the strip (one across per 0.25 L / H of it)"),
    }
    variants = {"corotated": {}, "green": {"strain": "green"}, "linear": {"strain": "linear"},
                "green_mujoco_probe": {"strain": "green", "force": 10.0, "length": 1.0,
                                       "height": 1.0, "cells": 1}}
    default_variants = ("corotated", "green", "linear")
    quick_variants = ("corotated",)

    def _cells(self, p):
        nx = int(p["cells"])
        return nx, max(1, round(nx * p["height"] / p["length"]))

    def _lambda(self, p):
        return stretch(p["strain"], p["force"], p["youngs_modulus"],
                       p["thickness"] * p["height"])

    def mesh(self, p):
        nx, ny = self._cells(p)
        nodes, tris = rectangle_triangles(nx, ny, p["length"], p["height"])
        left = np.flatnonzero(nodes[:, 0] == 0.0)
        right = np.flatnonzero(nodes[:, 0] == nodes[:, 0].max())
        loads = np.zeros_like(nodes)
        share = np.full(len(right), 1.0 / ny)
        share[np.argmin(nodes[right, 1])] = share[np.argmax(nodes[right, 1])] = 0.5 / ny
        loads[right, 0] = p["force"] * share
        material = Material(p["youngs_modulus"], 0.0, 1.0, p["strain"])
        return TriangleMesh(nodes, tris, material, thickness=p["thickness"], plane="stress",
                            pinned=left, loads=loads)

    def exact(self, p):
        nodes = np.array(self.mesh(p).vertices)
        nodes[:, 0] *= self._lambda(p)
        return nodes

    def scene(self, p):
        return Scene(parts=(self.mesh(p),), gravity=(0.0, 0.0, 0.0), meta={"solve": "static"})

    def extra_metrics(self, p, obs, observed, reference):
        out = super().extra_metrics(p, obs, observed, reference)
        x = observed["x"][-1]
        right = x[:, 0].argmax()
        out["stretch"] = float(x[right, 0] / p["length"])
        out["stretch_exact"] = self._lambda(p)
        return out


CASE = UniaxialStretch()
