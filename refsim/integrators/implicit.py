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


SPARSE_MIN = 96  # state size (32 bodies) from which Baraff-Witkin solves sparsely


class BaraffWitkin(Integrator):
    """Baraff & Witkin (1998) linearised backward Euler for spring systems:

    (M - h df/dv - h^2 df/dx) dv = h (f0 + h df/dx v0).
    One Newton step of backward Euler from v0; identical to it for linear forces.

    Small or batched states (below SPARSE_MIN, or with batch axes) solve it divided through by
    M with dense Jacobians. A single state of SPARSE_MIN or more, on a system offering
    `sparse_force_jacobians(t, x, v)` (CSR force Jacobians, or None), solves the symmetric
    form above with scipy.sparse: `solver="direct"` (SuperLU) or `"cg"` (conjugate gradient
    from dv = 0 to relative residual `rtol`; the matrix is symmetric, and positive definite
    while no spring is compressed below its rest length: Baraff & Witkin's caveat, sec. 5.2;
    `StepFailure` when CG does not converge).
    """

    name, order, family, explicit = "baraff_witkin", 1, "implicit (linearised)", False

    def __init__(self, solver="direct", rtol=1e-10):
        if solver not in ("direct", "cg"):
            raise ValueError(f"baraff_witkin solver must be 'direct' or 'cg', got {solver!r}")
        self.solver, self.rtol = solver, float(rtol)

    def describe(self) -> dict:
        return {**super().describe(), "solver": self.solver,
                "rtol": self.rtol if self.solver == "cg" else None,
                "sparse_from_state_size": SPARSE_MIN}

    def _sparse_step(self, system, t, x, v, h, shift):
        import scipy.sparse as sp
        from scipy.sparse.linalg import cg, spsolve
        jacobians = system.sparse_force_jacobians(t, x, v)
        if jacobians is None:
            return None
        kx, kv = jacobians
        m = np.repeat(system.masses, 3)
        matrix = (sp.diags(m) - h * kv - (h * h) * kx).tocsr()
        rhs = h * (m * system.accel(t, x, v) + h * (kx @ v))
        if self.solver == "direct":
            dv = spsolve(matrix.tocsc(), rhs)
        else:
            dv, info = cg(matrix, rhs, rtol=self.rtol, atol=0.0, maxiter=10 * len(rhs))
            if info != 0:
                raise StepFailure(f"baraff_witkin CG did not reach rtol {self.rtol:g} "
                                  f"(info {info}; a compressed spring makes the matrix "
                                  "indefinite)")
        v1 = v + dv
        return (shift(x, h * v1), v1)

    def _step(self, system, t, state, h, shift):
        x, v = state
        if np.ndim(x) == 1 and np.size(x) >= SPARSE_MIN and \
                hasattr(system, "sparse_force_jacobians"):
            out = self._sparse_step(system, t, x, v, h, shift)
            if out is not None:
                return out
        jac, ax = implicit_matrix(system, t, x, v, h)
        rhs = h * (system.accel(t, x, v) + h * matvec(ax, v))
        v1 = v + solve(jac, rhs)
        return (shift(x, h * v1), v1)
