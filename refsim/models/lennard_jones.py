"""Lennard-Jones pair forces (the `LennardJones` part; equations in refsim/scene/lennard_jones.py):
forces, potential energy and virial over the pairs within the cut-off (a cell list,
refsim.models.cell_list) or over all pairs (cutoff = inf), vectorised over pairs and over any
leading batch axes, in 2D or 3D (the positions' last axis).

`LennardJonesSystem` is the stepper's system (refsim/integrators/base.py): flat states
(..., 3 n) of 3D particle coordinates, the pair forces acting on the first `dim` of them (a 2D
scene moves in the plane z = 0: its z accelerations are zero).
"""
from __future__ import annotations

import math

import numpy as np

from .cell_list import neighbour_pairs, pair_search, squared_norm


def pair_potential(r, epsilon=1.0, sigma=1.0, cutoff=math.inf, shift=False):
    """U(r) of one pair (J): 4 eps ((s/r)^12 - (s/r)^6) [- U_LJ(r_c)] inside r_c, 0 beyond."""
    r = np.asarray(r, float)
    s6 = (sigma / r) ** 6
    u = 4.0 * epsilon * (s6 * s6 - s6)
    if shift and math.isfinite(cutoff):
        c6 = (sigma / cutoff) ** 6
        u = u - 4.0 * epsilon * (c6 * c6 - c6)
    return np.where(r < cutoff, u, 0.0)


def _pair_terms(sep, epsilon, sigma, cutoff, shift):
    """(u, g) per pair: the energy and g = -U'(r)/r, so that the force on j is g sep."""
    r2 = np.einsum("...k,...k->...", sep, sep)
    s2 = sigma * sigma / r2
    s6 = s2 * s2 * s2
    u = 4.0 * epsilon * (s6 * s6 - s6)
    if shift and math.isfinite(cutoff):
        c6 = (sigma / cutoff) ** 6
        u -= 4.0 * epsilon * (c6 * c6 - c6)
    g = 24.0 * epsilon * (2.0 * s6 * s6 - s6) / r2
    return u, g


class LennardJonesModel:
    """The part's parameters and the pair search: forces, energy, virial of positions
    (..., n, d). `box` (d,) periodic lengths or None."""

    def __init__(self, epsilon=1.0, sigma=1.0, cutoff=math.inf, shift=False, box=None):
        self.epsilon, self.sigma = float(epsilon), float(sigma)
        self.cutoff, self.shift = float(cutoff), bool(shift)
        self.box = None if box is None else np.asarray(box, float)
        self.dense = math.isinf(self.cutoff)  # every pair: (..., n, n, d) arrays

    def _dense_forces(self, x):
        """All pairs as dense (..., n, n, d) separations (no cut-off: the model's few-body
        scenes): F_i = -sum_j g_ij (x_j - x_i), the diagonal excluded."""
        sep = x[..., None, :, :] - x[..., :, None, :]  # [i, j] = x_j - x_i
        n = x.shape[-2]
        diagonal = np.eye(n, dtype=bool)
        sep[..., diagonal, :] = 1.0  # any non-zero separation; its g is zeroed below
        _, g = _pair_terms(sep, self.epsilon, self.sigma, self.cutoff, self.shift)
        g[..., diagonal] = 0.0
        return -np.einsum("...ij,...ijk->...ik", g, sep)

    @classmethod
    def of_part(cls, part):
        return cls(part.epsilon, part.sigma, part.cutoff, part.shift, part.box)

    def pairs(self, x):
        """(i, j, sep) of the pairs within the cut-off (cell list) or all pairs (inf)."""
        return neighbour_pairs(x, self.cutoff, self.box)

    def forces(self, x):
        """Forces (..., n, d) on each particle (N): g sep on j, its opposite on i, for each
        pair i < j (in the cell list's order, so the sums round as they always have), summed
        in the cell list's sorted numbering, then unsorted."""
        x = np.asarray(x, float)
        if self.dense:
            return self._dense_forces(x)
        found = pair_search(x, self.cutoff, self.box)
        g = self._g(squared_norm(found.sep))
        swap = found.order[found.first] > found.order[found.second]  # first is j: sep = -sep
        i, j = np.where(swap, found.second, found.first), np.where(swap, found.first,
                                                                    found.second)
        g[swap] *= -1.0  # g (-sep) = -(g sep) exactly
        rows = int(np.prod(x.shape[:-1]))
        out = np.empty((rows, x.shape[-1]))
        for k, sep in enumerate(found.sep):  # a loop over the 2 or 3 axes
            pair_force = g * sep  # on j; its opposite on i
            out[found.order, k] = (np.bincount(j, pair_force, minlength=rows)
                                   - np.bincount(i, pair_force, minlength=rows))
        return out.reshape(x.shape)

    def _g(self, r2):
        """g = -U'(r)/r = 24 eps (2 (s/r)^12 - (s/r)^6) / r^2 of squared distances."""
        s2 = self.sigma * self.sigma / r2
        s6 = s2 * s2 * s2
        return 24.0 * self.epsilon * (2.0 * s6 * s6 - s6) / r2

    def energy(self, x):
        """Potential energy (J) per instance, shape x.shape[:-2]."""
        x = np.asarray(x, float)
        i, _, sep = self.pairs(x)
        u, _ = _pair_terms(sep, self.epsilon, self.sigma, self.cutoff, self.shift)
        return self._per_instance(x, i, u)

    def virial(self, x):
        """W = sum over pairs of r . F(r) = sum g r^2 (J) per instance (the pressure's
        interaction part: P V = N k T + W / d)."""
        x = np.asarray(x, float)
        i, _, sep = self.pairs(x)
        _, g = _pair_terms(sep, self.epsilon, self.sigma, self.cutoff, self.shift)
        return self._per_instance(x, i, g * np.einsum("ij,ij->i", sep, sep))

    def pair_count(self, x) -> int:
        """How many pairs lie within the cut-off (all instances)."""
        return len(self.pairs(x)[0])

    @staticmethod
    def _per_instance(x, i, values):
        n = x.shape[-2]
        batch = int(np.prod(x.shape[:-2], dtype=np.int64))
        return np.bincount(i // n, values, minlength=batch).reshape(x.shape[:-2])


class LennardJonesSystem:
    """Particles (masses (n,)) under the pair forces, for the steppers: flat (..., 3 n) state;
    `dim` = 2 moves the plane z = 0 (forces on x, y only)."""

    linear = False
    velocity_dependent = False

    def __init__(self, masses, model: LennardJonesModel, dim=3):
        self.masses = np.asarray(masses, float)
        self.nbody, self.model, self.dim = len(self.masses), model, int(dim)
        self.inv_m = (1.0 / self.masses)[:, None]

    def accel(self, t, x, v):
        xb = x.reshape(x.shape[:-1] + (self.nbody, 3))
        a = np.zeros_like(xb)
        a[..., :self.dim] = self.model.forces(xb[..., :self.dim]) * self.inv_m
        return a.reshape(x.shape)

    def potential_energy(self, positions):
        """U (J) of positions (..., n, 3), shape: the batch axes."""
        return self.model.energy(np.asarray(positions, float)[..., :self.dim])

    def stages(self) -> list[str]:
        search = ("all_pairs" if math.isinf(self.model.cutoff)
                  else "cell_list" + ("_periodic" if self.model.box is not None else ""))
        return [f"lennard_jones:{search}"]
