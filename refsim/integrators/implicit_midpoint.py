"""The implicit midpoint rule, on a vector space or (through `shift`) on a Lie group.

One stage, the Gauss-Legendre method of order 2 (symmetric; symplectic on a vector space):

    V = v + h/2 a(t + h/2, X, V),   X = x (+) h/2 K,   K = V (or dexpinv(h/2 K, V))
    x_1 = x (+) h K,                v_1 = v + h a(t + h/2, X, V) = 2 V - v

On a vector space X = (x + x_1)/2 and V = (v + v_1)/2: the classical implicit midpoint rule.
With a system `shift` (the exponential map of the rotations) it is the one-stage Gauss
Runge-Kutta-Munthe-Kaas method (the Lie midpoint rule), still symmetric and of order 2; the
`dexpinv` correction (when the system has it) changes only O(h^3) terms of the increment.

Solved by fixed-point iteration on V (each sweep contracts by about h/2 |da/dv|, so h |w|/2 for
a tumbling body): converged when the update is below `tol` (1 + max |V|), `StepFailure` after
`max_iter` sweeps. The default tol 1e-14 is a few ulps of |V| (the iteration's own round-off
floor is about eps |V| = 2.2e-16 |V| per sweep), so the solve adds no error the order
measurements see.
"""
from __future__ import annotations

import numpy as np

from .base import Integrator, StepFailure, plain_addition


class ImplicitMidpoint(Integrator):
    name, order, family = "implicit_midpoint", 2, "implicit (Gauss-Legendre)"
    explicit, symplectic = False, True

    def __init__(self, tol=1e-14, max_iter=100):
        self.tol, self.max_iter = tol, max_iter

    def describe(self) -> dict:
        return {**super().describe(), "implicit": True, "solver": "fixed-point iteration",
                "tol": self.tol, "max_iter": self.max_iter}

    def _slope(self, system, dexpinv, dx, vm):
        return vm if dexpinv is None else dexpinv(dx, vm)

    def _step(self, system, t, state, h, shift):
        x, v = state
        dexpinv = None if shift is plain_addition else getattr(system, "dexpinv", None)
        half, tm = 0.5 * h, t + 0.5 * h
        vm = v + half * system.accel(t, x, v)  # explicit Euler half step: the first guess
        k = vm
        for _ in range(self.max_iter):
            k = self._slope(system, dexpinv, half * k, vm)
            vm_new = v + half * system.accel(tm, shift(x, half * k), vm)
            change = np.max(np.abs(vm_new - vm))
            vm = vm_new
            if change <= self.tol * (1.0 + np.max(np.abs(vm))):
                break
        else:
            raise StepFailure(f"implicit_midpoint: fixed-point iteration did not converge in "
                              f"{self.max_iter} sweeps (h too large for h |da/dv| / 2 < 1)")
        k = self._slope(system, dexpinv, half * k, vm)
        return (shift(x, h * k), 2.0 * vm - v)
