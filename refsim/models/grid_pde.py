"""Linear PDEs on a regular grid by the method of lines (slides 000/001): the heat equation
u_t = D lap u and the wave equation u_tt = c^2 lap u, lap the finite-difference Laplacian of
`refsim.models.grid_laplacian`. Physics only: the steppers are `refsim.integrators`' (explicit
tableaux and Verlet on arrays of any shape) and `refsim.integrators.sparse_linear`'s (implicit,
one sparse LU per run).

A `Grid` part with model "diffusion" carries coefficients {"diffusivity": D (m^2/s)} and one
field (u); with model "wave", {"wave_speed": c (m/s)} and two fields, u (displacement) and
v (its rate; zero if absent).
"""
from __future__ import annotations

import math

import numpy as np

from .grid_laplacian import GridLaplacian

COEFFICIENT = {"diffusion": ("diffusivity", 1), "wave": ("wave_speed", 2)}
MODELS = tuple(COEFFICIENT)


def coefficient_reason(grid) -> str | None:
    """Why the grid cannot be run as a linear PDE (None when it can)."""
    if grid.model not in COEFFICIENT:
        return f"grid.model must be one of {list(MODELS)} for a linear PDE, got {grid.model!r}"
    name, _ = COEFFICIENT[grid.model]
    value = grid.coefficients.get(name)
    if value is None or not value > 0 or not math.isfinite(value):
        return f"grid.coefficients[{name!r}] must be a number > 0 for {grid.model}, got {value}"
    return None


class GridPDE:
    """The right-hand side A u, A = D lap (diffusion) or c^2 lap (wave), both as a first-order
    field (`velocity`) and a second-order system (`accel`), and as a sparse matrix."""

    linear = True
    velocity_dependent = False

    def __init__(self, grid):
        reason = coefficient_reason(grid)
        if reason:
            raise ValueError(reason)
        self.model = grid.model
        name, power = COEFFICIENT[grid.model]
        self.coefficient_name, self.coefficient_value = name, grid.coefficients[name]
        self.factor = self.coefficient_value ** power  # D or c^2
        self.laplacian = GridLaplacian.of(grid)
        self._matrix = self._diagonals = None

    def apply(self, u):
        """A u: one sparse product for a single field in diagonal (DIA) storage (the stencil's
        2d + 1 diagonals, each one contiguous multiply-add: 4.3 ms at 1025^2 against CSR's
        4.9 ms and the slices' 11 ms, measured), the slices for a batch of fields."""
        u = np.asarray(u, float)
        if u.shape != self.laplacian.shape:
            return self.factor * self.laplacian.apply(u)
        if self._diagonals is None:
            self._diagonals = self.matrix().todia()
        return (self._diagonals @ u.reshape(-1)).reshape(u.shape)

    def velocity(self, t, u):
        return self.apply(u)

    def accel(self, t, x, v):
        return self.apply(x)

    def matrix(self):
        if self._matrix is None:
            self._matrix = (self.factor * self.laplacian.matrix()).tocsr()
        return self._matrix

    def describe(self) -> str:
        equation = {"diffusion": "u_t = D lap u", "wave": "u_tt = c^2 lap u"}[self.model]
        return (f"{equation}, {self.coefficient_name} = {self.coefficient_value:g}; "
                f"{self.laplacian.describe()}")
