"""Static equilibrium of an elastic body by Newton's method: f_int(x) + f_ext = 0 on the free
dofs, the fixed dofs held at prescribed positions (pinned nodes, or an imposed boundary
field).

Each iteration solves K_ff dx_f = f_int(x)_f + f_ext,f with the tangent K = -df/dx
(refsim.models.fem.assembly, pattern found once) by scipy.sparse.linalg.spsolve (SuperLU), and
stops when max |residual_f| <= rtol x the force scale (the largest of |f_ext| and the internal
forces, reactions included), or when the update is below the positions' round-off
(max |dx| <= 16 eps max |x|: forces computed from positions carry eps |x| / h relative
round-off, so the residual of a stiff or large body stalls there). The linear law's forces
are affine in x: one step solves it exactly, and it stops there. Loads may be applied in
`steps` equal increments (each solved to convergence) for large deformations.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse.linalg import spsolve

from .assembly import Assembler


ROUND_OFF = 16 * np.finfo(float).eps  # an update below this x max |x| moves nothing


class StaticFailure(RuntimeError):
    """Newton did not reach the tolerance."""


@dataclass
class StaticResult:
    x: np.ndarray  # (n, d) equilibrium positions
    iterations: int  # Newton iterations in all
    residual: float  # max |residual| on the free dofs at the end (N)
    scale: float  # the force scale the tolerance is relative to (N)


def solve_static(body, loads, fixed, x0=None, rtol=1e-10, max_iter=50, steps=1,
                 assembler=None) -> StaticResult:
    """Equilibrium positions of `body` (ElasticBody) under nodal loads (n, d), N; `fixed` (n, d)
    bool marks the dofs held at their values in x0 (default: the rest positions)."""
    assembler = assembler or Assembler(body)
    x = np.array(body.elements.rest if x0 is None else x0, float)
    fixed = np.broadcast_to(np.asarray(fixed, bool), x.shape)
    free = ~fixed.reshape(-1)
    loads = np.asarray(loads, float)
    total = 0
    for step in range(1, steps + 1):
        x, iterations, residual, scale = _newton(body, assembler, x, free,
                                                 loads * (step / steps), rtol, max_iter)
        total += iterations
    return StaticResult(x, total, residual, scale)


def _newton(body, assembler, x, free, loads, rtol, max_iter):
    linear = body.linear
    for iteration in range(max_iter + 1):
        f_int = body.forces(x)
        residual = (f_int + loads).reshape(-1)[free]
        scale = max(np.abs(loads).max(initial=0.0), np.abs(f_int).max(initial=0.0))
        worst = np.abs(residual).max(initial=0.0)
        if worst <= rtol * scale or scale == 0.0:
            return x, iteration, worst, scale
        if iteration == max_iter:
            break
        k = assembler.stiffness(x)[free][:, free]
        flat = x.reshape(-1).copy()
        dx = spsolve(k.tocsc(), residual)
        flat[free] += dx
        x = flat.reshape(x.shape)
        if linear or np.abs(dx).max(initial=0.0) <= ROUND_OFF * np.abs(flat).max():
            return x, iteration + 1, worst, scale
    raise StaticFailure(f"static Newton: max |residual| {worst:.3g} N above {rtol:g} x "
                        f"{scale:.3g} N after {max_iter} iterations")
