"""What the finite-difference cases share: the grid of a Fourier mode on the unit cube and its
exact discrete and continuum eigenvalues, and the amplification factor of each heat stepper.

A mode of wavenumber k on every axis of a unit-length grid of `cells` intervals:
- dirichlet: N = cells + 1 points x_j = j h, h = 1 / cells, phi = prod sin(k pi x);
- neumann:   the same points, phi = prod cos(k pi x);
- periodic:  N = cells points (x_N is x_0), phi = prod cos(2 pi k x).
Per axis the phase per point is theta = k pi h (2 pi k h periodic); the Laplacian's discrete
eigenvalue is -(4 / h^2) sin^2(theta / 2) (refsim.models.grid_laplacian.mode_eigenvalue), the
continuum one -(k pi)^2 (-(2 pi k)^2 periodic); in d dimensions d times these.
"""
from __future__ import annotations

import math

import numpy as np

from refsim.case import Case
from refsim.integrators.first_order import get_first_order
from refsim.integrators.sparse_linear import first_order_implicit
from refsim.integrators.spec import spec_name
from refsim.models.grid_laplacian import mode_eigenvalue
from refsim.scene import Grid, Scene

BOUNDARIES = ("dirichlet", "neumann", "periodic")


class ModeGrid:
    """The unit grid of parameters p: dim, cells, k, boundary (and seed for noise)."""

    def __init__(self, p):
        self.dim, self.cells, self.k = int(p["dim"]), int(p["cells"]), int(p["k"])
        self.boundary = str(p["boundary"])
        self.h = 1.0 / self.cells
        self.points = self.cells if self.boundary == "periodic" else self.cells + 1
        self.shape = (self.points,) * self.dim
        self.wave = (2.0 if self.boundary == "periodic" else 1.0) * math.pi * self.k
        if self.k < 1 or self.wave * self.h >= math.pi:
            raise ValueError(f"k must be in [1, {self.max_k()}] for {self.cells} cells "
                             f"({self.boundary}), got {self.k}")

    def max_k(self) -> int:
        return (self.cells - 1) // 2 if self.boundary == "periodic" else self.cells - 1

    def axis(self) -> np.ndarray:
        return np.arange(self.points) * self.h

    def mode(self) -> np.ndarray:
        """phi on the grid (amplitude 1)."""
        shape1 = np.sin if self.boundary == "dirichlet" else np.cos
        line = shape1(self.wave * self.axis())
        if self.boundary == "dirichlet":
            line[[0, -1]] = 0.0  # sin(k pi) rounds to ~1e-16: the boundary is exactly zero
        out = line
        for _ in range(self.dim - 1):
            out = np.multiply.outer(out, line)
        return out

    def noise(self, seed: int) -> np.ndarray:
        """Zero-mean uniform noise in [-1, 1] (zero on Dirichlet sides): every mode present."""
        u = np.random.default_rng(int(seed)).uniform(-1.0, 1.0, self.shape)
        if self.boundary == "dirichlet":
            inner = tuple(slice(1, -1) for _ in range(self.dim))
            fixed = np.ones(self.shape, bool)
            fixed[inner] = False
            u[fixed] = 0.0
        else:
            u -= u.mean()
        return u

    def discrete_eigenvalue(self) -> float:
        """The mode's eigenvalue of the d-dimensional discrete Laplacian (1/m^2)."""
        return float(self.dim * mode_eigenvalue(self.wave * self.h, self.h))

    def continuum_eigenvalue(self) -> float:
        return -self.dim * self.wave ** 2

    def weights(self) -> np.ndarray:
        """Trapezoid quadrature weights (m^d): the inner product in which the discrete
        Laplacian with mirrored Neumann points is self-adjoint."""
        line = np.full(self.points, self.h)
        if self.boundary != "periodic":
            line[[0, -1]] *= 0.5
        out = line
        for _ in range(self.dim - 1):
            out = np.multiply.outer(out, line)
        return out

    def top_eigenvalue(self) -> float:
        """|largest| eigenvalue of the d-dimensional discrete Laplacian on this grid (the
        sawtooth: exactly d 4/h^2 on even periodic grids, below it otherwise)."""
        if self.boundary == "periodic":
            theta = math.pi if self.cells % 2 == 0 else math.pi * (1 - 1.0 / self.cells)
        else:
            theta = math.pi * (self.cells - 1) / self.cells if self.boundary == "dirichlet" \
                else math.pi
        return float(-self.dim * mode_eigenvalue(theta, self.h))

    def scene(self, model: str, fields: dict, coefficients: dict) -> Scene:
        grid = Grid(shape=self.shape, spacing=self.h, model=model, boundary=self.boundary,
                    fields=fields, coefficients=coefficients)
        return Scene(parts=(grid,), gravity=(0.0, 0.0, 0.0))


class ModeFieldCase(Case):
    """What the heat and wave mode cases share: the grid of their parameters, its points as
    the bodies, the compared field u (grid.u) and its error, the max over grid points."""

    observable, units = "u", "1 (of the initial amplitude)"

    def grid(self, p) -> ModeGrid:
        return ModeGrid(p)

    def bodies(self, p):
        return int(np.prod(self.grid(p).shape))

    def observables(self, p, obs):
        return {"u": np.asarray(obs["grid.u"], float)}

    def error(self, p, observed, reference):
        diff = np.asarray(observed["u"]) - np.asarray(reference["u"])
        return np.max(np.abs(diff.reshape(len(diff), -1)), axis=1)


def heat_stepper(integrator: str):
    """The first-order stepper of that name (its `stability(z)` is R(z))."""
    name = spec_name(integrator)
    if name in ("explicit_euler", "implicit_euler", "crank_nicolson"):
        return first_order_implicit(name)
    return get_first_order(integrator)


def stages(integrator: str) -> int:
    """Stencil evaluations per step (for the round-off bound)."""
    name = spec_name(integrator)
    return {"explicit_euler": 1, "midpoint": 2, "heun": 2, "rk4": 4, "implicit_euler": 1,
            "crank_nicolson": 2}.get(name, 4)


def real_stability_limit(stepper) -> float:
    """Largest x with |R(-s)| <= 1 for every s in [0, x] (inf for the implicit theta
    methods): the explicit tableau's real stability interval, by bisection to 1e-12 on the
    first s where |R(-s)| > 1 on a fine grid."""
    if not stepper.explicit:
        return math.inf
    grid = np.linspace(0.0, 8.0, 80001)
    bad = np.flatnonzero(np.abs(stepper.stability(-grid)) > 1.0 + 1e-14)
    lo, hi = grid[bad[0] - 1], grid[bad[0]]
    while hi - lo > 1e-12:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if abs(stepper.stability(-mid)) <= 1.0 else (lo, mid)
    return float(lo)

