"""The prescribed flows of the advection tests (refsim.scene.prescribed_flow; issue 27, case 4),
evaluated analytically wherever a stepper or a backtrace asks (no grid sampling of u).

`Flow.velocity_2d(t, points)` maps points (..., 2) to u (..., 2); `Flow.velocity(t, p)` is the
first-order system refsim.integrators.first_order steps (p (..., n, 3), z velocity 0), with
`linear` and `jacobian` where the flow is affine (the rotation: implicit Euler runs on it).

- single vortex (LeVeque 1996): u = sin^2(pi x) sin(2 pi y) g(t), v = -sin(2 pi x)
  sin^2(pi y) g(t), g = cos(pi t / T). Divergence-free (u = d psi/dy, v = -d psi/dx with
  psi = sin^2(pi x) sin^2(pi y) g / pi), zero normal velocity on the unit square's sides;
  since g(T - t) = -g(t), the flow from T/2 to T retraces the flow from 0 to T/2 backwards:
  the flow map at T is the identity;
- Zalesak's rotation: u = omega (c_y - y), v = omega (x - c_x), u = M (p - c) with
  M = [[0, -omega], [omega, 0]].
"""
from __future__ import annotations

import numpy as np


class Flow:
    """A PrescribedFlow part's field (2D, in the plane z = 0)."""

    def __init__(self, part):
        self.name, self.period = part.flow, float(part.period)
        self.omega, self.centre = float(part.omega), np.array(part.centre, float)
        self.linear = part.affine
        if self.linear:
            self.matrix = np.array([[0.0, -self.omega, 0.0], [self.omega, 0.0, 0.0],
                                    [0.0, 0.0, 0.0]])

    def velocity_2d(self, t, points) -> np.ndarray:
        """u (..., 2) at points (..., 2) and time t (s)."""
        x, y = points[..., 0], points[..., 1]
        if self.name == "leveque_vortex":
            g = np.cos(np.pi * t / self.period)
            sx, sy = np.sin(np.pi * x), np.sin(np.pi * y)
            return np.stack([sx * sx * np.sin(2 * np.pi * y) * g,
                             -np.sin(2 * np.pi * x) * sy * sy * g], axis=-1)
        return np.stack([self.omega * (self.centre[1] - y),
                         self.omega * (x - self.centre[0])], axis=-1)

    def velocity(self, t, p) -> np.ndarray:
        """The first-order system's u(t, p) for p (..., n, 3): z velocity 0."""
        out = np.zeros_like(p, dtype=float)
        out[..., :2] = self.velocity_2d(t, p[..., :2])
        return out

    def jacobian(self, t, p) -> np.ndarray:
        """du/dp (3, 3), the same for every particle (the rotation only)."""
        if not self.linear:
            raise ValueError("the single vortex is not affine in p: no constant Jacobian")
        return self.matrix

    def describe(self) -> str:
        if self.name == "leveque_vortex":
            return (f"single vortex (LeVeque 1996): u = sin^2(pi x) sin(2 pi y) cos(pi t/T), "
                    f"v = -sin(2 pi x) sin^2(pi y) cos(pi t/T), T = {self.period:g} s, "
                    "evaluated analytically")
        return (f"rigid rotation (Zalesak 1979): u = omega (c_y - y), v = omega (x - c_x), "
                f"omega = {self.omega:.9g} rad/s, c = ({self.centre[0]:g}, "
                f"{self.centre[1]:g}) m, evaluated analytically")


__all__ = ["Flow"]
