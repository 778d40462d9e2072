"""All-pairs Newtonian gravity (the `GravityPairs` part): accelerations and potential energy,
vectorised over pairs and over any leading batch axes. No cut-off: every pair interacts, as
the long-ranged potential demands (see refsim/scene/gravity_pairs.py for the equations).

Cost: O(n^2) memory and time per evaluation, as (..., n, n, 3) separations; fine to n ~ 10^4
(8 n^2 3 bytes = 2.4 GB at 10^4: callers evaluate such n in row blocks, `block_rows`).
"""
from __future__ import annotations

import numpy as np


def pair_accelerations(x, masses, G=1.0, softening=0.0, block_rows=None):
    """Accelerations a_i = sum_{j != i} G m_j (x_j - x_i) / (|x_j - x_i|^2 + eps^2)^(3/2) of
    positions x (..., n, 3) with masses (n,); same shape as x. `block_rows`: evaluate the rows
    i in blocks of that many (bounds the (..., b, n, 3) temporary), None: all at once."""
    x = np.asarray(x, float)
    masses = np.asarray(masses, float)
    n = x.shape[-2]
    step = n if block_rows is None else int(block_rows)
    out = np.empty_like(x)
    eps2 = float(softening) ** 2
    for start in range(0, n, step):  # a loop over row BLOCKS, not particles (one at n <= step)
        rows = slice(start, min(start + step, n))
        d = x[..., None, :, :] - x[..., rows, None, :]  # (..., b, n, 3): x_j - x_i
        r2 = np.einsum("...k,...k->...", d, d) + eps2
        idx = np.arange(rows.start, rows.stop)
        r2[..., np.arange(len(idx)), idx] = np.inf  # no self-interaction
        inv_r3 = r2 ** -1.5
        out[..., rows, :] = G * np.einsum("...ij,...ijk->...ik", inv_r3 * masses, d)
    return out


def potential_energy(x, masses, G=1.0, softening=0.0):
    """U = - sum_{i<j} G m_i m_j / sqrt(|x_j - x_i|^2 + eps^2), shape x.shape[:-2]."""
    x = np.asarray(x, float)
    masses = np.asarray(masses, float)
    i, j = np.triu_indices(x.shape[-2], k=1)
    d = x[..., j, :] - x[..., i, :]
    r = np.sqrt(np.einsum("...k,...k->...", d, d) + float(softening) ** 2)
    return -G * np.sum(masses[i] * masses[j] / r, axis=-1)


def pair_jacobian(x, masses, G=1.0, softening=0.0):
    """da/dx of `pair_accelerations`, shape (..., 3n, 3n), analytic: for i != j the 3x3 block
    da_i/dx_j = G m_j (I / s^3 - 3 d d^T / s^5), d = x_j - x_i, s^2 = |d|^2 + eps^2, and the
    diagonal block da_i/dx_i = -sum_{j != i} G m_j (I / s^3 - 3 d d^T / s^5) (a_i depends on x_i
    through every d). Dense: for the small systems an implicit stepper solves (n <~ 100)."""
    x = np.asarray(x, float)
    masses = np.asarray(masses, float)
    n = x.shape[-2]
    d = x[..., None, :, :] - x[..., :, None, :]  # (..., n, n, 3): x_j - x_i
    s2 = np.einsum("...k,...k->...", d, d) + float(softening) ** 2
    s2[..., np.arange(n), np.arange(n)] = np.inf  # no self-interaction: its block is 0
    inv_s3 = s2 ** -1.5
    eye = np.eye(3)
    block = G * masses[:, None, None] * (inv_s3[..., None, None] * eye - 3.0 * (
        inv_s3 / s2)[..., None, None] * d[..., :, None] * d[..., None, :])  # (..., n, n, 3, 3)
    diag = -np.sum(block, axis=-3)  # (..., n, 3, 3): minus the sum over j of row i's blocks
    block[..., np.arange(n), np.arange(n), :, :] = diag
    return np.swapaxes(block, -3, -2).reshape(x.shape[:-2] + (3 * n, 3 * n))


def kinetic_energy(v, masses):
    """T = sum 1/2 m_i |v_i|^2 of velocities (..., n, 3), shape v.shape[:-2]."""
    return 0.5 * np.einsum("i,...ik,...ik->...", np.asarray(masses, float), v, v)


def total_energy(x, v, masses, G=1.0, softening=0.0):
    """E = T + U (J), shape x.shape[:-2]."""
    return kinetic_energy(v, masses) + potential_energy(x, masses, G, softening)


def total_momentum(v, masses):
    """P = sum m_i v_i, shape (..., 3)."""
    return np.einsum("i,...ik->...k", np.asarray(masses, float), v)


def angular_momentum(x, v, masses):
    """L = sum m_i x_i x v_i about the origin, shape (..., 3)."""
    return np.einsum("i,...ik->...k", np.asarray(masses, float), np.cross(x, v))


def runge_lenz(x, v, masses, G=1.0):
    """The eccentricity (Laplace-Runge-Lenz) vector of a two-body problem, dimensionless:
    e = v x h / (G M) - r / |r| of the relative orbit r = x_2 - x_1, v = v_2 - v_1, h = r x v,
    M = m_1 + m_2 (|e| is the eccentricity; it points to the periapsis). Conserved by Newton's
    law (eps = 0) only. Shape (..., 3) from x, v (..., 2, 3)."""
    masses = np.asarray(masses, float)
    if x.shape[-2] != 2 or masses.shape != (2,):
        raise ValueError(f"runge_lenz needs exactly 2 bodies, got {x.shape[-2]}")
    r, w = x[..., 1, :] - x[..., 0, :], v[..., 1, :] - v[..., 0, :]
    h = np.cross(r, w)
    return np.cross(w, h) / (G * masses.sum()) - r / np.linalg.norm(r, axis=-1, keepdims=True)


class GravitySystem:
    """All-pairs gravity in the form the steppers take: flat state (..., 3n) with any leading
    batch axes, accel(t, x, v) = pair_accelerations (+ a uniform field `gravity`), analytic
    `jacobians` for the implicit steppers (da/dv = 0). Not linear, not velocity dependent.
    `block_rows` bounds the (..., b, n, 3) temporaries of large n (None: all rows at once)."""

    linear = False
    velocity_dependent = False

    def __init__(self, masses, G=1.0, softening=0.0, gravity=(0.0, 0.0, 0.0),
                 block_rows=None):
        self.masses = np.asarray(masses, float)
        self.nbody = len(self.masses)
        self.G, self.softening, self.block_rows = float(G), float(softening), block_rows
        self.gravity = np.asarray(gravity, float)
        self.has_field = bool(np.any(self.gravity))

    def _bodies(self, flat):
        return np.asarray(flat, float).reshape(np.shape(flat)[:-1] + (self.nbody, 3))

    def accel(self, t, x, v):
        a = pair_accelerations(self._bodies(x), self.masses, self.G, self.softening,
                               self.block_rows)
        if self.has_field:
            a = a + self.gravity
        return a.reshape(np.shape(x))

    def jacobians(self, t, x, v):
        jx = pair_jacobian(self._bodies(x), self.masses, self.G, self.softening)
        return jx, np.zeros_like(jx)

    def energy(self, x, v):
        """E = T + U - sum m g . x, on flat states."""
        xb, vb = self._bodies(x), self._bodies(v)
        out = total_energy(xb, vb, self.masses, self.G, self.softening)
        if self.has_field:
            out = out - np.einsum("i,...ik,k->...", self.masses, xb, self.gravity)
        return out

    def invariants(self, x, v) -> dict:
        """energy, momentum, angular_momentum (and runge_lenz for two bodies) of flat states."""
        xb, vb = self._bodies(x), self._bodies(v)
        out = {"energy": self.energy(x, v), "momentum": total_momentum(vb, self.masses),
               "angular_momentum": angular_momentum(xb, vb, self.masses)}
        if self.nbody == 2:
            out["runge_lenz"] = runge_lenz(xb, vb, self.masses, self.G)
        return out
