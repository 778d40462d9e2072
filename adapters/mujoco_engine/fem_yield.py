"""MuJoCo 4's flex plasticity (`<elasticity yield>`, mujoco 4.0.0) mapped to refsim's von Mises
rule (refsim.models.fem.plasticity), for the fem group (groups/fem.py).

MuJoCo's rule, as measured on one tetrahedron (tests/engines/mujoco/test_mujoco_fem.py; the
documentation says "von Mises (J2) ... via radial return mapping", and stores "plastic metric
offsets"): the flex keeps per element a plastic metric offset P (3 x 3 symmetric, stored as
t^T P t over the element's 6 edges t, `d.plastic` at `flex_plasticadr`, edges in `flex_edge`
order); the elastic strain is E - P / 2 with E the Green strain; the element yields where
sqrt(2/3) |dev(E - P/2)| > eps_y (the `yield` value, a strain); the return is radial in the
deviatoric elastic strain, back to |dev(E - P/2)| = sqrt(3/2) eps_y, and the volumetric part
of P is set so that det(I + P) = 1 (isochoric in the metric); the update runs once per mj_step,
at the end-of-step positions; the elastic forces of every stage (RK4 included) use the
committed P, without a return.

refsim's rule on the green law: |2 mu dev(E - E_p)| <= sqrt(2/3) sigma_y, the same radial
return with E_p = P / 2 in its deviatoric part, so eps_y = sigma_y / (3 mu) gives the same
yield surface and the same deviatoric flow. What differs:
- the volumetric plastic strain: refsim keeps tr E_p = 0, MuJoCo det(I + 2 E_p) = 1, i.e.
  tr E_p = |dev E_p|^2 + O(|E_p|^3) (measured in the plastic_set green variant: see its test);
- the return inside a step: refsim's forces return from the committed state at every force
  evaluation (RK4's stages included), MuJoCo's do not (the stages see the elastic trial);
  equal for single-stage methods (Euler), whose force is taken at committed positions.
MuJoCo's yield is ideal (no hardening), on triangles a plane-stress return with thinning
(refsim builds plasticity in plane strain only): those scenes are refused.
"""
from __future__ import annotations

import numpy as np

from refsim.scene import TriangleMesh

WHO = "mujoco fem"


def yield_reason(mesh, static: bool) -> str | None:
    """Why MuJoCo's flex yield cannot run the mesh's plasticity (None when it can)."""
    plastic = mesh.material.plasticity
    if plastic is None:
        return None
    if isinstance(mesh, TriangleMesh):
        return (f"{WHO}: plasticity on triangles: MuJoCo's 2-D flex yield is a plane-stress "
                "return with out-of-plane thinning, refsim's plasticity runs in plane strain")
    if plastic.hardening != 0:
        return f"{WHO}: MuJoCo's flex yield is ideal (no hardening), got H = {plastic.hardening:g}"
    if plastic.yield_stress == 0:
        return f"{WHO}: sigma_y = 0 (MuJoCo's yield 0 means an elastic flex)"
    if static:
        return (f"{WHO}: a plastic static scene: the plastic strain depends on the path, and "
                "MuJoCo reaches equilibria only by damped dynamics (a path of its own)")
    return None


def yield_strain(mesh) -> float:
    """MuJoCo's `yield` (a strain) for refsim's sigma_y: eps_y = sigma_y / (3 mu) (0 if
    elastic)."""
    plastic = mesh.material.plasticity
    if plastic is None:
        return 0.0
    mat = mesh.material
    mu = mat.youngs_modulus / (2.0 * (1.0 + mat.poisson_ratio))
    return plastic.yield_stress / (3.0 * mu)


def plastic_metrics(model, data, vertices) -> np.ndarray:
    """(elements, 3, 3) MuJoCo's plastic metric offsets P of the one flex (3-D), solved from
    the per-edge values t^T P t of each tetrahedron's 6 edges (`flex_elemedge` order; t from
    the rest `vertices`)."""
    adr, count = model.flex_elemedgeadr[0], model.flex_elemnum[0]
    edges = model.flex_edge.reshape(-1, 2)[model.flex_elemedge[adr:adr + 6 * count]]
    t = (vertices[edges[:, 1]] - vertices[edges[:, 0]]).reshape(count, 6, 3)
    rows, cols = np.triu_indices(3)
    weights = np.where(rows == cols, 1.0, 2.0)
    a = t[:, :, rows] * t[:, :, cols] * weights  # (count, 6 edges, 6 unknowns)
    values = data.plastic[model.flex_plasticadr[0]:][:6 * count].reshape(count, 6)
    upper = np.linalg.solve(a, values[..., None])[..., 0]
    out = np.zeros((count, 3, 3))
    out[:, rows, cols] = upper
    out[:, cols, rows] = upper
    return out


def describe(mesh) -> dict | None:
    """settings['plasticity'] (None for an elastic mesh)."""
    plastic = mesh.material.plasticity
    if plastic is None:
        return None
    return {
        "mujoco": "flex <elasticity yield=eps_y> (stretching; ideal von Mises on the Green "
                  "strain, radial return once per mj_step at the end-of-step positions)",
        "yield_stress": plastic.yield_stress, "yield_strain": yield_strain(mesh),
        "mapping": "eps_y = sigma_y / (3 mu): MuJoCo's sqrt(2/3) |dev E_e| <= eps_y is "
                   "refsim's |2 mu dev E_e| <= sqrt(2/3) sigma_y",
        "differs": "volumetric plastic strain: MuJoCo det(I + 2 E_p) = 1, refsim tr E_p = 0 "
                   "(tr E_p = |dev E_p|^2 to leading order); RK4 stages use the committed "
                   "plastic strain without a return (refsim returns at every stage)",
    }
