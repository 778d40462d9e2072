"""Mutual Newtonian gravity between the scene's particles: the `GravityPairs` part.

Every pair of the scene's particles (`Scene(parts=(Particles(...), GravityPairs()))`)
attracts with the force of Newton's law, softened by a Plummer length eps:

    F_ij = G m_i m_j (x_j - x_i) / (|x_j - x_i|^2 + eps^2)^(3/2)       (on i, from j)
    U    = - sum_{i<j} G m_i m_j / sqrt(|x_j - x_i|^2 + eps^2)

eps = 0 (the default) is Newton's law itself. All pairs interact (no cut-off: the potential
is long-ranged, so a cell list would change the physics); momentum, angular momentum and the
energy E = sum 1/2 m |v|^2 + U are conserved by the flow, and the Runge-Lenz vector of a
two-body orbit when eps = 0. The scene's uniform `gravity` (a field) may be set beside it.
Observables are the particles' (x, v: refsim/observation.py).
"""
from __future__ import annotations

from dataclasses import dataclass

from ._validate import ArrayPart, _nonnegative, _positive, _set


@dataclass(frozen=True, eq=False)
class GravityPairs(ArrayPart):
    """G (m^3 kg^-1 s^-2) > 0, the gravitational constant (1 in the reduced units the orbit
    cases use); softening (m) >= 0, the Plummer length eps."""

    G: float = 1.0
    softening: float = 0.0

    kind = "gravity_pairs"

    def __post_init__(self):
        _set(self, "G", _positive("gravity_pairs.G", self.G))
        _set(self, "softening", _nonnegative("gravity_pairs.softening", self.softening))

    def features(self) -> set[str]:
        return {"gravity_pairs"}
