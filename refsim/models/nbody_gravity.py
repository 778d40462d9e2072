"""All-pairs Newtonian gravity (the `GravityPairs` part): accelerations and potential energy,
vectorised over pairs and over any leading batch axes. No cut-off: every pair interacts, as
the long-ranged potential demands (see refsim/scene/gravity_pairs.py for the equations).

Cost of `pair_accelerations`: O(n^2) time; memory O(n^2) only for n <= DENSE_MAX_BODIES, else
the blocked path's cache-sized work arrays (5 x BLOCK_ELEMENTS floats, or 5 n per instance
when one row is larger), reused between calls. `potential_energy` and `pair_jacobian` stay
dense (O(n^2) memory: the energy checks and the implicit steppers' few bodies).
"""
from __future__ import annotations

import threading

import numpy as np

DENSE_MAX_BODIES = 32  # above: the blocked path (measured crossover, benchmarks/nbody.py)
BLOCK_ELEMENTS = 1 << 16  # pair entries per block: 0.5 MB per work array, 5 of them
_SELF_INF: dict = {}  # n -> (n, n): inf on the diagonal, 0 elsewhere
_WORK = threading.local()  # the blocked path's work array, reused between calls


def pair_accelerations(x, masses, G=1.0, softening=0.0, block_rows=None):
    """Accelerations a_i = sum_{j != i} G m_j (x_j - x_i) / (|x_j - x_i|^2 + eps^2)^(3/2) of
    positions x (..., n, 3) with masses (n,); same shape as x.

    Three paths, one law: two bodies (the default run's ~10^5 calls: least overhead), a few
    (n <= DENSE_MAX_BODIES: one dense (..., n, n, 3) pass), and many (`_blocked`: rows in
    cache-sized blocks, per-axis separations, 1 / (r^2 sqrt r^2)). The first two are the
    original dense formula's operations (its doubles wherever numpy's r2 ** -1.5 rounds as
    Python's: not on AVX-512, an ulp apart); the blocked one differs from it by round-off only
    (each term to a few eps, the sum to ~n eps of sum_j |term|:
    tests/models/test_nbody_gravity.py).
    `block_rows`: at most that many rows i per block (bounds the (..., b, n) temporaries;
    None: the cache-sized default, BLOCK_ELEMENTS pair entries per block)."""
    x = np.asarray(x, float)
    masses = np.asarray(masses, float)
    n = x.shape[-2]
    eps2 = float(softening) ** 2
    if n == 2:
        return _two_bodies(x, masses, float(G), eps2)
    if n <= DENSE_MAX_BODIES:
        return _dense(x, masses, G, eps2)
    return _blocked(x, masses, G, eps2, block_rows)


def _two_bodies(x, masses, G, eps2):
    """a_0 = G m_1 d / s^3, a_1 = -G m_0 d / s^3, d = x_1 - x_0: the dense formula's own
    rounding (r^2 summed (d_x^2 + d_z^2) + d_y^2 as numpy's einsum does, r2 ** -1.5, a single
    product per body), in Python floats for one pair, numpy for a batch."""
    if x.ndim == 2:
        (x0, y0, z0), (x1, y1, z1) = x.tolist()
        m0, m1 = masses.tolist()
        dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
        inv_r3 = ((dx * dx + dz * dz) + dy * dy + eps2) ** -1.5
        w0, w1 = inv_r3 * m0, inv_r3 * m1
        return np.array([[G * (w1 * dx), G * (w1 * dy), G * (w1 * dz)],
                         [G * (w0 * -dx), G * (w0 * -dy), G * (w0 * -dz)]])
    d = x[..., 1, :] - x[..., 0, :]
    inv_r3 = (np.einsum("...k,...k->...", d, d) + eps2) ** -1.5
    out = np.empty(x.shape)
    out[..., 0, :] = (inv_r3 * masses[1])[..., None] * d
    out[..., 1, :] = (inv_r3 * masses[0])[..., None] * -d
    out *= G
    return out


def _dense(x, masses, G, eps2):
    """All rows at once as dense (..., n, n, 3) separations; the diagonal's r^2 is inf."""
    n = x.shape[-2]
    d = x[..., None, :, :] - x[..., :, None, :]  # (..., n, n, 3): x_j - x_i
    r2 = np.einsum("...k,...k->...", d, d) + eps2
    r2 += _self_inf(n)  # no self-interaction: + inf on the diagonal, + 0 elsewhere
    return G * np.einsum("...ij,...ijk->...ik", r2 ** -1.5 * masses, d)


def _self_inf(n):
    mask = _SELF_INF.get(n)
    if mask is None:
        mask = _SELF_INF[n] = np.where(np.eye(n, dtype=bool), np.inf, 0.0)
    return mask


def _blocked(x, masses, G, eps2, block_rows):
    """Rows i in blocks of b: per axis k the separations d_k (B, b, n) = x_jk - x_ik, r^2,
    w = m_j / (r^2 sqrt r^2) (the diagonal's r^2 set to inf: w = 0), a_ik = sum_j w d_k
    (einsum row dots). Work arrays reused from block to block and call to call."""
    n = x.shape[-2]
    cols = np.ascontiguousarray(np.moveaxis(x.reshape(-1, n, 3), -1, 0))  # (3, B, n)
    instances = cols.shape[1]
    rows = max(1, min(n, BLOCK_ELEMENTS // (instances * n)))
    if block_rows is not None:
        rows = max(1, min(rows, int(block_rows)))
    out = np.empty((3, instances, n))
    size = instances * rows * n
    work = _work_buffer(5 * size)  # d (3 size), r2, w
    for start in range(0, n, rows):  # a loop over row BLOCKS, not particles
        stop = min(start + rows, n)
        m = instances * (stop - start) * n
        d = work[:3 * m].reshape(3, instances, stop - start, n)
        r2 = work[3 * size:3 * size + m].reshape(d.shape[1:])
        w = work[4 * size:4 * size + m].reshape(d.shape[1:])
        for k in range(3):  # the three axes
            np.subtract(cols[k][:, None, :], cols[k][:, start:stop, None], out=d[k])
        np.einsum("kbij,kbij->bij", d, d, out=r2)
        if eps2:
            r2 += eps2
        r2[:, np.arange(stop - start), np.arange(start, stop)] = np.inf
        np.sqrt(r2, out=w)
        w *= r2
        np.divide(masses, w, out=w)
        for k in range(3):
            np.einsum("bij,bij->bi", w, d[k], out=out[k, :, start:stop])
    out *= G
    return np.ascontiguousarray(np.moveaxis(out, 0, -1)).reshape(x.shape)


def _work_buffer(size):
    """A float64 work array of `size`, kept per thread and grown when a call needs more."""
    buffer = getattr(_WORK, "buffer", None)
    if buffer is None or buffer.size < size:
        buffer = _WORK.buffer = np.empty(size)
    return buffer[:size]


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
