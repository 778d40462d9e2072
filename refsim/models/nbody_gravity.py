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
