"""The exact discrete equilibrium of a hanging chain of point masses on elastic links, and its
continuum limit, the catenary (docs/models.md#springs-hanging-chain).

Links i = 0..N-1 join nodes i and i + 1; nodes 0 and N are pinned at (0, 0) and (S, 0) in the
x-z plane; the free nodes 1..N-1 carry weights w_j = m_j g. Link i pulls node i towards i + 1
with the tension vector t_i = (H, V_i); node j's balance t_j - t_{j-1} + (0, -w_j) = 0 gives
a constant horizontal tension H and V_i = V0 + sum_{j<=i} w_j (V0 < 0: the first link points
down). Link i has tension T_i = sqrt(H^2 + V_i^2) and length l0 + T_i / k = l0 (1 + T_i / EA)
(k in N/m, EA = k l0 in N: the "l0 (1 + T_i / k_s)" of docs/models.md#springs-hanging-chain
has k_s = EA in N) along t_i / T_i:
    d_i = (l0 / T_i + 1 / k) (H, V_i)      (k = inf: inextensible).
The two unknowns (H, V0) close the chain: sum d_i = (S, 0). `chain_equilibrium` solves that by
bisection on H (sum d_x is increasing in H) at the symmetric V0, then Newton on both with the
exact Jacobian until the residual stops falling (~1e-16 relative); every node follows by a
cumulative sum.

Catenary (k = inf, N -> inf, uniform mass per length rho = M / L): z = a (cosh((x - S/2) / a)
- cosh(S / (2 a))), a = H / (rho g), with 2 a sinh(S / (2 a)) = L.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq


@dataclass(frozen=True)
class ChainEquilibrium:
    nodes: np.ndarray      # (N + 1, 2): x, z of every node (m)
    horizontal: float      # H (N)
    first_vertical: float  # V0 (N), the vertical tension of link 0 (negative: it points down)
    tensions: np.ndarray   # (N,) T_i (N)
    residual: float        # |sum d_i - (S, 0)| / S after the root find


def _links(h, v0, weights, rest, k):
    """(d (N, 2), dd/dH (N, 2), dd/dV0 (N, 2)) of every link at (H, V0)."""
    vert = v0 + np.concatenate([[0.0], np.cumsum(weights)])
    tension = np.hypot(h, vert)
    scale = rest / tension + 1.0 / k
    d = np.stack([scale * h, scale * vert], 1)
    dscale = -rest / tension ** 3  # d(scale)/dT / T: d(scale)/dH = dscale h, /dV = dscale V
    d_dh = np.stack([scale + dscale * h * h, dscale * h * vert], 1)
    d_dv = np.stack([dscale * h * vert, scale + dscale * vert * vert], 1)
    return d, d_dh, d_dv


def chain_equilibrium(weights, rest: float, stiffness: float, span: float,
                      newton_steps: int = 8) -> ChainEquilibrium:
    """The exact equilibrium of N = len(weights) + 1 links (module doc). `weights` (N-1,) the
    free nodes' weights m g (N), `rest` l0 (m), `stiffness` k (N/m, inf allowed), `span` S."""
    weights = np.asarray(weights, float)
    n_links = len(weights) + 1
    if not 0.0 < span < n_links * rest:
        raise ValueError(f"span must be in (0, {n_links * rest:g}) m (the chain's rest length "
                         f"N l0), got {span}")
    v0 = -0.5 * float(weights.sum())  # exact for a symmetric chain; Newton corrects it

    def gap(h):
        return float(np.sum(_links(h, v0, weights, rest, stiffness)[0][:, 0]) - span)

    lo, hi = 1e-12 * max(weights.sum(), 1e-300), max(weights.sum(), 1e-300)
    while gap(hi) < 0:
        hi *= 2.0
    h = brentq(gap, lo, hi, xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=500)
    target = np.array([span, 0.0])
    best = None
    for _ in range(newton_steps):
        d, d_dh, d_dv = _links(h, v0, weights, rest, stiffness)
        res = d.sum(0) - target
        norm = float(np.linalg.norm(res)) / span
        if best is not None and norm >= best[0]:
            break
        best = (norm, h, v0)
        jac = np.stack([d_dh.sum(0), d_dv.sum(0)], 1)
        dh, dv = np.linalg.solve(jac, -res)
        h, v0 = h + dh, v0 + dv
    norm, h, v0 = best
    d = _links(h, v0, weights, rest, stiffness)[0]
    nodes = np.vstack([[0.0, 0.0], np.cumsum(d, 0)])
    nodes[-1] = (span, 0.0)  # the pin itself (the root find put the chain's end there)
    vert = v0 + np.concatenate([[0.0], np.cumsum(weights)])
    return ChainEquilibrium(nodes, float(h), float(v0), np.hypot(h, vert), norm)


def catenary_parameter(length: float, span: float) -> float:
    """a with 2 a sinh(S / (2 a)) = L (L > S > 0)."""
    if not 0.0 < span < length:
        raise ValueError(f"span must be in (0, {length:g}) m (the chain length), got {span}")
    return brentq(lambda a: 2 * a * math.sinh(span / (2 * a)) - length, span / 700.0,
                  1e6 * length, xtol=1e-300, rtol=4 * np.finfo(float).eps)


def catenary_sag(length: float, span: float) -> float:
    """Depth of the catenary's lowest point below the pins (m)."""
    a = catenary_parameter(length, span)
    return a * (math.cosh(span / (2 * a)) - 1.0)
