"""The one stepper for every explicit Runge-Kutta tableau (`tableaux`), on y = (x, v), y' = (v, a).

Stage i (V_1 = v, A_1 = a(t, x, v)):

    X_i = x (+) h sum_j a_ij V_j     V_i = v + h sum_j a_ij A_j     A_i = a(t + c_i h, X_i, V_i)
    x_1 = x (+) h sum_i b_i V_i      v_1 = v + h sum_i b_i A_i

where x (+) dx is the system's configuration update (`base.configuration_update`).

- Plain addition (a system without `shift`): the terms (a_ij h) V_j are added to x one at a
  time, left to right, exactly the arithmetic of the stepper before the hook existed.
- A system `shift` (a Lie group such as the unit quaternions): X_i = shift(x, h sum_j a_ij
  K_j), x_1 = shift(x, h sum_i b_i K_i): the increment is summed in the tangent space (the Lie
  algebra) and mapped once. With the system hook `dexpinv(dx, v)` (the inverse differential
  of the map dx -> shift(x, dx), closed form for SO(3)) the stage slopes are
  K_i = dexpinv(X_i's increment, V_i) (K_1 = v): Runge-Kutta-Munthe-Kaas (Munthe-Kaas 1998;
  Iserles et al., Acta Numerica 2000, section 4), which keeps the tableau's order p on the
  group. Without the hook K_i = V_i ("RKMK-lite"): the tableau's order whenever the stage
  increments commute (a vector space, a rotation about a fixed axis) and min(p, 2) on a general
  non-commutative group (the dropped commutator terms are O(h^3) a step; measured on a
  tumbling top in tests/models/test_rigid_orientation.py). The increment differs from plain
  addition's sum in the last bits only (the terms are summed before they meet x), so an
  identity `shift` reproduces plain addition to round-off, and bit for bit where every sum has
  one term (explicit Euler, midpoint). Systems without `shift` or `dexpinv` run exactly the
  arithmetic they ran before the hooks existed.

The tableau's coefficients are multiplied by h inside the step (no per-h cache), so h may be a
float or an array (one h per batch member, shape (batch, 1)).
"""
from __future__ import annotations

import numpy as np

from .base import Integrator, configuration_update, plain_addition
from .tableaux import Tableau


def increment_origin(shift, x, v):
    """What a sum x (+) sum_j c_j k_j starts from: x itself under plain addition (the terms
    join x one at a time), else a zero tangent increment shaped like v (shifted onto x once,
    at the end)."""
    return x if shift is plain_addition else np.zeros(np.shape(v))


class ExplicitRK(Integrator):
    """One stepper for every explicit Runge-Kutta tableau (see the module docstring)."""

    family = "explicit Runge-Kutta"

    def __init__(self, name: str, tableau: Tableau):
        self.name, self.tableau, self.order = name, tableau, tableau.order
        a, b, c = tableau.arrays()
        # the stages after the first (which has no couplings), each (c_i, ((j, a_ij), ...))
        # with its non-zero couplings only, as plain floats (a numpy scalar would turn a
        # plain-float state into numpy scalars, three times slower per operation)
        self._later_stages = tuple(
            (float(c[i]), tuple((j, float(a[i, j])) for j in range(i) if a[i, j] != 0))
            for i in range(1, len(c)))
        self._weights = tuple((i, float(b[i])) for i in range(len(b)) if b[i] != 0)

    def stages(self, system, t, x, v, h, shift=None):
        """The stage slopes (K_i, A_i), as two lists (K_i = V_i unless the system has
        `dexpinv`; `shift`: the system's update, resolved here when not given)."""
        if shift is None:
            shift = configuration_update(system)
        accel, plain = system.accel, shift is plain_addition
        dexpinv = None if plain else getattr(system, "dexpinv", None)
        origin = increment_origin(shift, x, v)
        kx, kv = [v], [accel(t, x, v)]  # explicit: the first stage has no couplings
        for ci, couplings in self._later_stages:
            xi, vi = origin, v  # xi: X_i under plain addition, else its increment from x
            for j, aij in couplings:
                haij = aij * h
                xi = xi + haij * kx[j]
                vi = vi + haij * kv[j]
            kx.append(vi if dexpinv is None else dexpinv(xi, vi))
            kv.append(accel(t + ci * h, xi if plain else shift(x, xi), vi))
        return kx, kv

    def _step(self, system, t, state, h, shift):
        x, v = state
        kx, kv = self.stages(system, t, x, v, h, shift)
        x1 = increment_origin(shift, x, v)  # x_1 under plain addition, else its increment
        for i, bi in self._weights:
            hbi = bi * h
            x1 = x1 + hbi * kx[i]
            v = v + hbi * kv[i]
        return (x1 if shift is plain_addition else shift(x, x1), v)
