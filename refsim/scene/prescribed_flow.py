"""A prescribed, time-dependent 2D velocity field that moves what the scene holds: the
`PrescribedFlow` part (kind "prescribed_flow"; issue 27, case 4, the advection tests).

Flows (MODELS.md section 5), in the plane z = 0, y up:
- "leveque_vortex" (LeVeque, SIAM J. Numer. Anal. 33, 1996, sec. 9.5): on the unit square
  u = sin^2(pi x) sin(2 pi y) cos(pi t / T), v = -sin(2 pi x) sin^2(pi y) cos(pi t / T); the
  field reverses at T/2 and the flow map at t = T is the identity: every shape returns to its
  start. `period` is T (s);
- "zalesak_rotation" (Zalesak, J. Comput. Phys. 31, 1979): the rigid rotation u = omega
  (c_y - y), v = omega (x - c_x) about `centre` at `omega` rad/s (pi/314 and (50, 50) in
  Zalesak's [0, 100]^2: one turn in 628 s); affine in the position.

What it moves, by the other parts of the scene:
- `Particles`: massless tracers, p' = u(t, p) (first order, refsim.integrators.first_order;
  masses and initial velocities ignored; z stays 0); observables "x" (n, 3) m and "v" (n, 3)
  m/s (u(t, p) at the observed p), as refsim/observation.py names them;
- a `Grid` of model "level_set" carrying one cell field "phi" (a level set, the shape being
  {phi < 0}), its points at the cell centres of the MAC convention (origin = spacing / 2, the
  same spacing on both axes): phi_t + u . grad phi = 0 by semi-Lagrangian advection
  (refsim.models.grid_fluid.level_set); observable "grid.phi" (the grid's shape), in the
  units of phi (m for a signed distance).
This part has no observables of its own.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ._validate import ArrayPart, _positive, _set, choice

FLOWS = ("leveque_vortex", "zalesak_rotation")


@dataclass(frozen=True, eq=False)
class PrescribedFlow(ArrayPart):
    """flow: one of FLOWS; period T (s, > 0; "leveque_vortex"); omega (rad/s, finite, non-zero;
    "zalesak_rotation") and centre (x, y) (m, finite; "zalesak_rotation")."""

    flow: str = "leveque_vortex"
    period: float = 8.0
    omega: float = math.pi / 314.0
    centre: tuple = (50.0, 50.0)

    kind = "prescribed_flow"

    def __post_init__(self):
        choice("prescribed_flow.flow", self.flow, FLOWS)
        _set(self, "period", _positive("prescribed_flow.period", self.period))
        omega = float(self.omega)
        if not math.isfinite(omega) or omega == 0.0:
            raise ValueError(f"prescribed_flow.omega must be finite and non-zero, got {omega}")
        _set(self, "omega", omega)
        centre = tuple(float(c) for c in self.centre)
        if len(centre) != 2 or not all(math.isfinite(c) for c in centre):
            raise ValueError(f"prescribed_flow.centre must be 2 finite numbers (x, y), got "
                             f"{self.centre!r}")
        _set(self, "centre", centre)

    def features(self) -> set[str]:
        return {"prescribed_flow", self.flow}

    @property
    def affine(self) -> bool:
        """True where u is affine in the position (the rotation)."""
        return self.flow == "zalesak_rotation"
