"""Lennard-Jones pair forces between the scene's particles: the `LennardJones` part.

Every pair of the scene's particles (`Scene(parts=(Particles(...), LennardJones(...)),
dim=2 or 3)`) interacts through the 12-6 potential, cut off at r_c and optionally shifted:

    U(r) = 4 eps ((sigma/r)^12 - (sigma/r)^6) - [shift] U_LJ(r_c)     for r < r_c, 0 beyond
    F_j  = -U'(r) (x_j - x_i) / r = 24 eps (2 (sigma/r)^12 - (sigma/r)^6) (x_j - x_i) / r^2

(F_j on j from i; F_i = -F_j). The minimum U(r0) = -eps lies at r0 = 2^(1/6) sigma. The
cut-off r_c = inf (the default) makes every pair interact; a finite r_c makes the force a
short-ranged one, found by a cell list (refsim.models.cell_list). With `shift` the potential
is continuous at r_c (the force still jumps by U'(r_c)); without it both jump.

`box`: None for open space, else the periodic lengths (L_1, .., L_dim) (m), one per axis of
the scene's dimension (2 or 3), minimum-image convention. Rule: every L_k >= 2 r_c (then a
pair within the cut-off has exactly one image within it), so a periodic box needs a finite
cut-off. The scene's dimension is checked by the engines (the part does not know it).
Momentum is conserved exactly by the flow (a symmetric pair force), and so is the energy
E = sum 1/2 m |v|^2 + U; open space conserves the angular momentum too. Observables are the
particles' (x, v: refsim/observation.py); positions are NOT wrapped into the box (the model
wraps them itself), so x is continuous in time.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ._validate import ArrayPart, _positive, _set


def _cutoff(value) -> float:
    value = float(value)
    if math.isnan(value) or value <= 0:
        raise ValueError(f"lennard_jones.cutoff must be > 0 (m; inf: every pair), got {value}")
    return value


def _box(value, cutoff):
    if value is None:
        return None
    try:
        lengths = tuple(float(v) for v in value)
    except TypeError:
        raise ValueError(f"lennard_jones.box must be None or 2 or 3 lengths (m), got "
                         f"{value!r}") from None
    if len(lengths) not in (2, 3):
        raise ValueError(f"lennard_jones.box must hold 2 or 3 lengths (one per axis of the "
                         f"scene's dimension), got {len(lengths)}")
    for length in lengths:
        if not math.isfinite(length) or length < 2.0 * cutoff:
            raise ValueError(f"lennard_jones.box lengths must be finite and >= 2 cutoff = "
                             f"{2.0 * cutoff:g} m (minimum image), got {lengths}")
    return lengths


@dataclass(frozen=True, eq=False)
class LennardJones(ArrayPart):
    """epsilon (J) > 0, the well depth; sigma (m) > 0, the zero of U; cutoff (m) > 0 or inf;
    shift: U shifted to 0 at the cut-off; box: None (open) or periodic lengths (m), each
    >= 2 cutoff."""

    epsilon: float = 1.0
    sigma: float = 1.0
    cutoff: float = math.inf
    shift: bool = False
    box: tuple | None = None

    kind = "lennard_jones"

    def __post_init__(self):
        _set(self, "epsilon", _positive("lennard_jones.epsilon", self.epsilon))
        _set(self, "sigma", _positive("lennard_jones.sigma", self.sigma))
        _set(self, "cutoff", _cutoff(self.cutoff))
        if not isinstance(self.shift, bool):
            raise ValueError(f"lennard_jones.shift must be True or False, got {self.shift!r}")
        if self.shift and math.isinf(self.cutoff):
            raise ValueError("lennard_jones.shift needs a finite cutoff (U(inf) = 0 already)")
        _set(self, "box", _box(self.box, self.cutoff))

    def features(self) -> set[str]:
        return {"lennard_jones"}

    @property
    def periodic(self) -> bool:
        return self.box is not None
