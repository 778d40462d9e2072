"""Timoshenko's cantilever in plane stress (Timoshenko & Goodier, Theory of Elasticity, 3rd ed.
1970, sec. 21; refsim.models.fem.cantilever): the beam [0, L] x [-D/2, D/2] of unit thickness,
L = 48, D = 12, E = 3e7, nu = 0.3 (linear law: the small-strain theory the exact field
solves), the exact displacement imposed on the edge x = 0 (pinned nodes held there) and the
parabolic shear traction of total P = 1000 on x = L as consistent nodal loads. The exact field
at the nodes is the reference; its tip deflection v(L, 0) = P L^3 / (3 E I) + (4 + 5 nu) P D^2
L / (24 E I) = 0.0089000 (I = D^3 / 12). Mesh: 4 n x n cells of right triangles, n = `cells`
across the depth.

Error: ||x - x_exact||_2 over every node (m). The P1 mesh cannot reach the exact field: its
discretisation error is not round-off (measured O(h^2) in L2 and O(h) in the energy norm:
tests/cases/test_fem_timoshenko.py). The bound is that error exactly: ||x_P1 - x_exact||_2
of the mesh's exact discrete solution, K u = f from the constant-strain triangle written out
in cases/fem/_linear.py (independent of refsim.models), plus twice the static solve's bound
of cases/fem/_static.py (once for the engine's solve, once for the case's own). By the
triangle inequality a solver of the same P1 problem stays within it; one whose solution
differs from x_P1 by d exceeds it once d's component along the discretisation error is above
the solve bounds: a stiffer beam (E 0.1 % high: P1 locking already deflects too little) or a
fully clamped edge is caught at every mesh (test), a 0.1 % softer E only once it outweighs
the discretisation error (it moves x towards x_exact).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from refsim.case import Param
from refsim.models.fem.cantilever import Cantilever
from refsim.scene import Material, Scene, TriangleMesh

from . import _linear
from ._static import NEWTON_RTOL, StaticCase


def beam(p) -> Cantilever:
    return Cantilever(p["length"], p["depth"], p["youngs_modulus"], p["poisson_ratio"],
                      p["load"])


def cells(p) -> tuple[int, int]:
    """(nx, ny): square-ish cells, ny = `cells` across the depth."""
    ny = int(p["cells"])
    return max(1, round(ny * p["length"] / p["depth"])), ny


@lru_cache(maxsize=16)
def discrete_solution(length, depth, youngs_modulus, poisson_ratio, load, nx, ny):
    """(n, 3) node positions of the P1 mesh's exact discrete solution (cases/fem/_linear)."""
    b = Cantilever(length, depth, youngs_modulus, poisson_ratio, load)
    nodes, tris = b.mesh(nx, ny)
    fixed, x0, loads = b.boundary(nodes)
    k = _linear.stiffness(nodes, tris, youngs_modulus, poisson_ratio, 1.0, "stress")
    u = _linear.solve(k, loads.reshape(-1), fixed.reshape(-1),
                      (x0 - nodes[:, :2]).reshape(-1))
    out = nodes.copy()
    out[:, :2] += u.reshape(-1, 2)
    return out


class Timoshenko(StaticCase):
    name = "timoshenko"
    description = ("Timoshenko's plane-stress cantilever, exact field on the clamped edge, "
                   "parabolic shear on the tip: the exact field at the nodes (v_tip 0.0089)")
    tags = ("fem", "static", "closed form", "convergence")
    params = {
        "cells": Param(4, 1, 64, "cells across the depth (4 x as many along L = 4 D)"),
        "length": Param(48.0, 1e-3, 1e4, "L (m)"),
        "depth": Param(12.0, 1e-3, 1e4, "D (m)"),
        "youngs_modulus": Param(3e7, 1e-6, 1e15, "E (Pa)", low_inclusive=False),
        "poisson_ratio": Param(0.3, -0.99, 0.49, "nu"),
        "load": Param(1000.0, -1e12, 1e12, "P (N), total shear on the tip"),
    }
    variants = {"n4": {}, "n2": {"cells": 2}, "n8": {"cells": 8}, "n16": {"cells": 16}}
    default_variants = ("n4",)
    quick_variants = ("n4",)

    def mesh(self, p):
        b = beam(p)
        nodes, tris = b.mesh(*cells(p))
        fixed, x0, loads = b.boundary(nodes)
        positions = nodes.copy()
        positions[:, :2] = x0
        loads3 = np.zeros_like(nodes)
        loads3[:, :2] = loads
        return TriangleMesh(nodes, tris, Material(p["youngs_modulus"], p["poisson_ratio"], 1.0,
                                                  "linear"),
                            thickness=1.0, plane="stress", pinned=np.flatnonzero(fixed[:, 0]),
                            loads=loads3, positions=positions)

    def exact(self, p):
        nodes, _ = beam(p).mesh(*cells(p))
        out = nodes.copy()
        out[:, :2] += beam(p).displacement(nodes[:, 0], nodes[:, 1])
        return out

    def discrete(self, p) -> np.ndarray:
        return discrete_solution(p["length"], p["depth"], p["youngs_modulus"],
                                 p["poisson_ratio"], p["load"], *cells(p))

    def scene(self, p):
        return Scene(parts=(self.mesh(p),), gravity=(0.0, 0.0, 0.0), meta={"solve": "static"})

    def solve_bound(self, p, rtol=NEWTON_RTOL):
        """StaticCase's bound, cached per parameters (a dense eigen-solve of the stiffness)."""
        return _solve_bound(tuple(sorted(p.items())), rtol)

    def discretisation_error(self, p) -> float:
        """||x_P1 - x_exact||_2 (m) of the mesh's exact discrete solution."""
        return float(np.linalg.norm(self.discrete(p) - self.exact(p)))

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        """The P1 mesh's own error plus twice the static solve's bound (module docstring)."""
        rtol = float((settings or {}).get("newton_rtol", NEWTON_RTOL))
        solve, solve_reason = self.solve_bound(p, rtol)
        p1 = self.discretisation_error(p)
        nx, ny = cells(p)
        return p1 + 2 * solve, (
            f"the {nx} x {ny}-cell P1 mesh's exact discrete solution (constant-strain "
            f"triangles, cases/fem/_linear.py) errs {p1:.4g} m from the exact field: the "
            f"discretisation error (O(h^2)), plus twice the static solve's bound "
            f"{solve:.3g} m ({solve_reason})")

    def extra_metrics(self, p, obs, observed, reference):
        out = super().extra_metrics(p, obs, observed, reference)
        nodes = self.mesh(p).vertices
        tip = np.flatnonzero((nodes[:, 0] == p["length"]) & (np.abs(nodes[:, 1]) <= 1e-12 *
                                                              p["depth"]))
        if len(tip):
            out["tip_deflection"] = float(observed["x"][-1][tip[0], 1])
            out["tip_deflection_exact"] = beam(p).tip_deflection()
            out["tip_deflection_p1"] = float(self.discrete(p)[tip[0], 1])
        return out


CASE = Timoshenko()


@lru_cache(maxsize=16)
def _solve_bound(items, rtol):
    return StaticCase.solve_bound(CASE, dict(items), rtol)
