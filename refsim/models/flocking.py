"""Flocking accelerations (the `Flocking` part), all pairs, vectorised over pairs and over any
leading batch axes, and the system the steppers take.

Cucker-Smale (Cucker & Smale 2007, IEEE TAC 52(5)):
    a_i = (1/N) sum_j psi(|x_i - x_j|) (v_j - v_i),   psi(r) = K / (sigma^2 + r^2)^beta.
The mean velocity is conserved, by the flow and by every stepper here, to round-off. Proof:
psi_ij = psi_ji (it depends on |x_i - x_j|) and (v_j - v_i) = -(v_i - v_j), so the pair terms
cancel in sum_i a_i = (1/N) sum_{i,j} psi_ij (v_j - v_i) = 0 (swap i and j: the sum equals its
own negative). This holds for ANY arguments (x, v), so every stage slope of an explicit RK
method, every kick of a symplectic or Verlet step and their sums have zero sum over particles:
each step changes sum_i v_i by a combination of zero sums (linear invariants are kept by every
Runge-Kutta method, Hairer, Lubich & Wanner, Geometric Numerical Integration, IV.1.2); the mean
position moves exactly with the mean velocity. In floating point each evaluation leaves
|sum_i a_i| <= N^2 eps max|psi| max|v_j - v_i| or so.

Flocking (Ha & Liu 2009, Kinet. Relat. Models 2(2), the Lyapunov-functional argument), with
V = (v_i - mean v), X = (x_i - mean x), |.| the l2 norm over all particles:
    d|V|^2/dt = -(1/N) sum_{ij} psi_ij |v_j - v_i|^2 <= -2 psi(D) |V|^2, D = max |x_i - x_j|;
    D <= 2|X| and d|X|/dt <= |V| give |V(t)| + (1/2) int_{2|X0|}^{2|X(t)|} psi <= |V0|, so
    2|X(t)| <= D_inf where (1/2) int_{2|X0|}^{D_inf} psi(s) ds = |V0| (`diameter_bound`),
    and |V(t)|^2 <= |V0|^2 exp(-2 psi(D_inf) t) (`variance_bound`).
For beta <= 1/2 the integral of psi diverges, so D_inf exists for every start: unconditional
flocking. Cost: O(N^2) per evaluation, (..., N, N, 3) temporaries (fine to N ~ 3000).
"""
from __future__ import annotations

import numpy as np
from numpy.polynomial.legendre import leggauss

_GAUSS_NODES, _GAUSS_WEIGHTS = leggauss(16)


def _differences(a):
    """(..., n, n, 3): a_j - a_i at [..., i, j, :]."""
    return a[..., None, :, :] - a[..., :, None, :]


def cucker_smale_accelerations(x, v, K=1.0, sigma=1.0, beta=0.25):
    """a_i = (1/N) sum_j psi(|x_i - x_j|) (v_j - v_i) of x, v (..., n, 3); same shape."""
    x, v = np.asarray(x, float), np.asarray(v, float)
    dx = _differences(x)
    r2 = np.einsum("...k,...k->...", dx, dx)
    psi = K * (sigma * sigma + r2) ** -beta
    # sum_j psi_ij (v_j - v_i) = (psi @ v)_i - v_i sum_j psi_ij: no (n, n, 3) velocity copy
    return (psi @ v - psi.sum(axis=-1)[..., None] * v) / x.shape[-2]


def reynolds_accelerations(x, v, radius, separation, alignment, cohesion):
    """Reynolds 1987's three rules over the neighbours 0 < |x_j - x_i| < radius (see
    refsim/scene/flocking.py): w_s sum_j (x_i - x_j)/|x_i - x_j|^2 + w_a (mean_j v_j - v_i) +
    w_c (mean_j x_j - x_i); a bird without neighbours gets none. Shape of x."""
    x, v = np.asarray(x, float), np.asarray(v, float)
    dx = _differences(x)
    r2 = np.einsum("...k,...k->...", dx, dx)
    near = (r2 > 0.0) & (r2 < radius * radius)
    count = near.sum(axis=-1)[..., None]
    inv_count = np.where(count > 0, 1.0 / np.maximum(count, 1), 0.0)
    weights = near.astype(float)
    inv_r2 = np.where(near, 1.0 / np.where(near, r2, 1.0), 0.0)
    sep = -np.einsum("...ij,...ijk->...ik", inv_r2, dx)
    mean_v = (weights @ v) * inv_count
    mean_x = (weights @ x) * inv_count
    has = count > 0
    return (separation * sep + alignment * np.where(has, mean_v - v, 0.0)
            + cohesion * np.where(has, mean_x - x, 0.0))


class FlockSystem:
    """The system the steppers take: flat (..., 3n) states, accel(t, x, v) of the rule."""

    linear = False
    velocity_dependent = True

    def __init__(self, flocking, nbody: int):
        self.flocking, self.nbody = flocking, int(nbody)

    def accel(self, t, x, v):
        shape = x.shape[:-1] + (self.nbody, 3)
        xb, vb = x.reshape(shape), v.reshape(shape)
        f = self.flocking
        if f.rule == "cucker_smale":
            a = cucker_smale_accelerations(xb, vb, f.K, f.sigma, f.beta)
        else:
            a = reynolds_accelerations(xb, vb, f.radius, f.separation, f.alignment,
                                       f.cohesion)
        return a.reshape(x.shape)

    def stages(self) -> list[str]:
        return [f"flocking:{self.flocking.rule}:all_pairs"]


def fluctuation_norm(a):
    """|A - mean A| (l2 over particles and components), shape a.shape[:-2]."""
    a = np.asarray(a, float)
    d = a - a.mean(axis=-2, keepdims=True)
    return np.sqrt(np.einsum("...ik,...ik->...", d, d))


def velocity_variance(v):
    """(1/N) sum_i |v_i - mean v|^2 (m^2/s^2), shape v.shape[:-2]."""
    return fluctuation_norm(v) ** 2 / np.asarray(v).shape[-2]


def psi_integral(a, b, K, sigma, beta):
    """int_a^b psi(s) ds (Gauss-Legendre, 16 points per sigma of length: psi is smooth on
    the scale sigma, the rule exact to degree 31 there)."""
    pieces = max(1, int(np.ceil((b - a) / sigma)))
    nodes, weights = _GAUSS_NODES, _GAUSS_WEIGHTS
    edges = np.linspace(a, b, pieces + 1)
    half = 0.5 * np.diff(edges)[:, None]
    s = 0.5 * (edges[1:] + edges[:-1])[:, None] + half * nodes
    return float(np.sum(half * weights * K * (sigma * sigma + s * s) ** -beta))


def diameter_bound(x0, v0, K, sigma, beta):
    """D_inf: (1/2) int_{2|X0|}^{D_inf} psi = |V0| (Ha & Liu 2009), by bisection; inf when
    the integral of psi stays below 2|V0| (beta > 1/2 and too fast a start)."""
    start, target = 2.0 * fluctuation_norm(x0), 2.0 * fluctuation_norm(v0)
    hi = start + sigma
    while psi_integral(start, hi, K, sigma, beta) < target:
        hi = start + 2.0 * (hi - start)
        if hi > 1e12 * (start + sigma):
            return np.inf
    lo = start
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if psi_integral(start, mid, K, sigma, beta) < target else (lo, mid)
    return hi


def variance_bound(x0, v0, t, K, sigma, beta):
    """Upper bound of velocity_variance(t): var(0) exp(-2 psi(D_inf) t)."""
    rate = K * (sigma * sigma + diameter_bound(x0, v0, K, sigma, beta) ** 2) ** -beta
    return velocity_variance(v0) * np.exp(-2.0 * rate * np.asarray(t, float))
