"""Witkin-Heckbert sampling of an implicit sphere: the `SurfaceSampling` part.

Witkin & Heckbert, "Using Particles to Sample and Control Implicit Surfaces", SIGGRAPH 94, as
slide 003 prints it: particles constrained to the iso-surface d(p) = |p - c| - R = 0 repel each
other with E_ij = alpha exp(-|p_i - p_j|^2 / (2 sigma^2)), E_i = sum_j (E_ij + E_ji), and move by
gradient descent on E_i, the tangential part of grad_{p_i} E_i, then are projected back onto
the surface. sigma is FIXED here (the paper adapts a sigma_i per particle to reach a target
density, and splits and kills particles; this part does neither).

First-order dynamics: masses and initial velocities of the particles are ignored. Observables
are the particles' "x" (n, 3) m and "v" (n, 3) m/s (the descent velocity at the observed p),
and the extra "repulsion_energy" () (sum_i E_i).
"""
from __future__ import annotations

from dataclasses import dataclass

from ._validate import ArrayPart, _positive, _set, _vec


@dataclass(frozen=True, eq=False)
class SurfaceSampling(ArrayPart):
    """An implicit sphere of `radius` R (m) > 0 about `centre` (m); repulsion width sigma (m)
    > 0 and amplitude alpha > 0."""

    radius: float = 1.0
    centre: tuple = (0.0, 0.0, 0.0)
    sigma: float = 0.5
    alpha: float = 1.0

    kind = "surface_sampling"

    def __post_init__(self):
        _set(self, "radius", _positive("surface_sampling.radius", self.radius))
        _set(self, "centre", _vec("surface_sampling.centre", self.centre))
        _set(self, "sigma", _positive("surface_sampling.sigma", self.sigma))
        _set(self, "alpha", _positive("surface_sampling.alpha", self.alpha))

    def features(self) -> set[str]:
        return {"first_order", "surface_sampling"}
