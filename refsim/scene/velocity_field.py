"""A prescribed velocity field moving the scene's particles: the `VelocityField` part.

FIRST-ORDER dynamics (slide 003): the particles are massless tracers, p' = u(t, p); their
masses and initial velocities are ignored (`Scene(parts=(Particles(...),
VelocityField(...)))`). Two affine fields, u = M (p - c):

- "rigid_vortex": u = Omega x (p - c) (M = [Omega]_x), a rigid rotation about the axis through
  `centre` along `omega` at rate |omega| (rad/s): |p - c| and the axial coordinate are
  conserved by the flow;
- "quadratic_descent": u = -grad E for E = 1/2 sum_k lambda_k (p_k - c_k)^2 (M = -diag(lambda),
  every lambda_k > 0, 1/s): gradient descent p_{i+1} = p_i - h grad E(p_i) is explicit Euler on
  it; each axis decays as exp(-lambda_k t).

Observables are the particles' "x" (n, 3) m and "v" (n, 3) m/s, the latter being u(t, p) at the
observed p (the tracer's velocity), as refsim/observation.py names them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._validate import ArrayPart, _set, _vec, choice

FIELDS = ("rigid_vortex", "quadratic_descent")


@dataclass(frozen=True, eq=False)
class VelocityField(ArrayPart):
    """field: one of FIELDS; centre c (m); omega (rad/s), the vortex's angular velocity
    (non-zero for "rigid_vortex"); rates lambda (1/s) per axis, each > 0 (for
    "quadratic_descent")."""

    field: str = "rigid_vortex"
    centre: tuple = (0.0, 0.0, 0.0)
    omega: tuple = (0.0, 0.0, 1.0)
    rates: tuple = (1.0, 1.0, 1.0)

    kind = "velocity_field"

    def __post_init__(self):
        choice("velocity_field.field", self.field, FIELDS)
        _set(self, "centre", _vec("velocity_field.centre", self.centre))
        _set(self, "omega", _vec("velocity_field.omega", self.omega))
        _set(self, "rates", _vec("velocity_field.rates", self.rates))
        if self.field == "rigid_vortex" and not any(self.omega):
            raise ValueError("velocity_field.omega must be non-zero for a rigid_vortex, got "
                             f"{self.omega}")
        if self.field == "quadratic_descent" and min(self.rates) <= 0:
            raise ValueError(f"velocity_field.rates must each be > 0, got {self.rates}")

    def features(self) -> set[str]:
        return {"first_order", "velocity_field"}

    def matrix(self) -> np.ndarray:
        """M (3, 3) of u = M (p - c)."""
        if self.field == "quadratic_descent":
            return -np.diag(self.rates)
        wx, wy, wz = self.omega
        return np.array([[0.0, -wz, wy], [wz, 0.0, -wx], [-wy, wx, 0.0]])
