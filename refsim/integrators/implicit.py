"""Implicit Euler (simplified Newton) and Baraff-Witkin's linearised backward Euler.

Both move the configuration through the system's update `shift(x, dx)`; under a `shift`, the
system's Jacobians are taken with respect to the tangent increment, so the Newton matrix has
the velocity's size n (equal to the configuration's for a system in a vector space).
"""
from __future__ import annotations

import numpy as np

from .base import Integrator, StepFailure


def solve(matrix, rhs):
    """matrix^-1 rhs over any batch axes; a plain division for a scalar state."""
    if np.ndim(rhs) == 0:  # scalar state (one degree of freedom, no batch)
        return rhs / matrix
    return np.linalg.solve(matrix, rhs[..., None])[..., 0]


def matvec(matrix, vector):
    """matrix @ vector over any batch axes; a product for a scalar state."""
    return matrix * vector if np.ndim(vector) == 0 else np.einsum("...ij,...j->...i", matrix,
                                                                  vector)


def implicit_matrix(system, t, x, v, h):
    """(I - h da/dv - h^2 da/dx, da/dx) at (t, x, v)."""
    ax, av = system.jacobians(t, x, v)
    eye = 1.0 if np.ndim(v) == 0 else np.eye(v.shape[-1])
    return eye - h * av - (h * h) * ax, ax


class ImplicitEuler(Integrator):
    """Backward Euler: v1 = v + h a(x + h v1, v1), x1 = x + h v1.

    Solved for v1 by simplified Newton (Hairer & Wanner, Solving ODEs II, IV.8): the matrix
    J = I - h da/dv - h^2 da/dx is formed once per step at the predictor v1 = v (x1 = x + h v)
    and reused. (The explicit-Euler predictor v + h a, used before, overshoots by h^2 a where
    the step is stiff, exactly where backward Euler is run: on the pendulum at omega dt = 29.7
    it put theta 880 times the amplitude away, where cos theta, hence J, is wrong enough that
    the iteration stalled: a `refsim stress` limit of 29.7 for an unconditionally stable
    method.) the iteration converges linearly at a rate of order h^2 |dJ|, and in one step for
    a linear system (the direct solve). Converged when the update is below `tol` relative to
    |v1|; `StepFailure` after `max_iter`.
    """

    name, order, family, explicit = "implicit_euler", 1, "implicit", False

    def __init__(self, tol=1e-13, max_iter=50):
        self.tol, self.max_iter = tol, max_iter

    def _step(self, system, t, state, h, shift):
        x, v = state
        t1 = t + h
        v1 = v
        jac, _ = implicit_matrix(system, t1, shift(x, h * v1), v1, h)
        for _ in range(1 if system.linear else self.max_iter):
            residual = v1 - v - h * system.accel(t1, shift(x, h * v1), v1)
            dv = solve(jac, residual)
            v1 = v1 - dv
            if system.linear or np.max(np.abs(dv)) <= self.tol * (1.0 + np.max(np.abs(v1))):
                break
        else:
            raise StepFailure(f"implicit_euler: Newton did not converge in {self.max_iter} "
                              "iterations")
        return (shift(x, h * v1), v1)


class BaraffWitkin(Integrator):
    """Baraff & Witkin (1998) linearised backward Euler for spring systems:

    (M - h df/dv - h^2 df/dx) dv = h (f0 + h df/dx v0), here divided through by M.
    One Newton step of backward Euler from v0; identical to it for linear forces.
    """

    name, order, family, explicit = "baraff_witkin", 1, "implicit (linearised)", False

    def _step(self, system, t, state, h, shift):
        x, v = state
        jac, ax = implicit_matrix(system, t, x, v, h)
        rhs = h * (system.accel(t, x, v) + h * matvec(ax, v))
        v1 = v + solve(jac, rhs)
        return (shift(x, h * v1), v1)
