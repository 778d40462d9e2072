"""The viscous term u_t = nu lap u on the MAC face arrays, explicit or implicit.

Each component is its own 5-point Laplacian on the faces that move (walls' normal faces and a
periodic axis' duplicate last face are fixed). Along the component's own axis its neighbours
are faces (a wall face is a Dirichlet value, 0); across it the wall lies half a cell beyond
the last face row, where the no-slip ghost u_g = 2 w - u_0 (w the wall's tangential velocity:
0, or the lid at the top for u) makes the row (u_1 - 3 u_0 + 2 w) / h^2. So lap u = M u + c
with M a sparse matrix (a Kronecker sum of the two 1D second differences) and c the lid's
constant term. Periodic axes wrap.
- "explicit": u <- u + dt nu (M u + c) (forward Euler; stable for nu dt / h^2 <= 1/4 in 2D);
- "implicit": (I - dt nu M) u_new = u + dt nu c (backward Euler, SuperLU, factorised once per
  dt and nu).
Both are first order in dt; M is second order in h (the ghost rows first order at the wall
rows, the usual MAC no-slip treatment). On a periodic grid a Fourier mode is an eigenvector
of M with eigenvalue -(4 / h^2) (sin^2(kx h / 2) + sin^2(ky h / 2)): the implicit step
multiplies it by exactly 1 / (1 + dt nu lambda) (lambda = -eigenvalue), the explicit one by
1 - dt nu lambda. Cell marks are not read here (every moving face is viscous).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .mac import MacGrid

SCHEMES = ("implicit", "explicit")


def second_difference(n: int, periodic: bool, staggered: bool):
    """(1D matrix of the unknowns, per-unknown weight of the low and high wall values).
    staggered: n + 1 faces along the axis (walls: the n - 1 inner ones move, ends are
    Dirichlet 0; periodic: n distinct faces); centred: n entries, walls half a cell out."""
    if periodic:
        m = sp.diags([np.ones(n - 1), -2.0 * np.ones(n), np.ones(n - 1)], [-1, 0, 1],
                     format="lil")
        m[0, n - 1] += 1.0
        m[n - 1, 0] += 1.0
        return m.tocsr(), np.zeros(n), np.zeros(n)
    size = n - 1 if staggered else n
    main = -2.0 * np.ones(size)
    low, high = np.zeros(size), np.zeros(size)
    if not staggered:  # no-slip ghost: (u_1 - 3 u_0 + 2 w) rows at both ends
        main[0] -= 1.0
        main[-1] -= 1.0
        low[0], high[-1] = 2.0, 2.0
    m = sp.diags([np.ones(size - 1), main, np.ones(size - 1)], [-1, 0, 1], format="csr")
    return m, low, high


class ViscousOperator:
    """lap on one face component ("u" or "v"): `M` (sparse, on the moving faces), `c` (the
    wall-velocity term), `moving` (slices of the component's array that move)."""

    def __init__(self, grid: MacGrid, component: str):
        self.grid, self.component = grid, component
        axis = 0 if component == "u" else 1
        mats, consts = [], []
        for a, n in enumerate(grid.cells):
            m, low, high = second_difference(n, grid.periodic[a], staggered=(a == axis))
            wall_low, wall_high = (0.0, grid.lid if (component == "u" and a == 1) else 0.0)
            mats.append(m)
            consts.append(low * wall_low + high * wall_high)
        nx_, ny_ = mats[0].shape[0], mats[1].shape[0]
        h2 = grid.h ** 2
        self.M = ((sp.kron(mats[0], sp.identity(ny_)) + sp.kron(sp.identity(nx_), mats[1]))
                  / h2).tocsr()
        self.c = (np.add.outer(consts[0], consts[1]) / h2).ravel()
        self.shape = (nx_, ny_)
        self.moving = tuple(
            slice(0, n) if grid.periodic[a] else (slice(1, n) if a == axis else slice(0, n))
            for a, n in enumerate(grid.cells))
        self._lu = {}

    def apply(self, a) -> np.ndarray:
        """lap a on the moving faces (their shape)."""
        return (self.M @ np.ravel(a[self.moving]) + self.c).reshape(self.shape)

    def step(self, a, dt, nu, scheme="implicit") -> np.ndarray:
        """The component after one viscous step (a new array; fixed faces unchanged)."""
        out = np.array(a, float)
        x = np.ravel(a[self.moving])
        if scheme == "explicit":
            new = x + dt * nu * (self.M @ x + self.c)
        elif scheme == "implicit":
            key = (float(dt), float(nu))
            if key not in self._lu:
                self._lu = {key: spla.splu((sp.identity(x.size) - dt * nu * self.M).tocsc())}
            new = self._lu[key].solve(x + dt * nu * self.c)
        else:
            raise ValueError(f"viscosity scheme must be one of {list(SCHEMES)}, got "
                             f"{scheme!r}")
        out[self.moving] = new.reshape(self.shape)
        return out


class Viscosity:
    """Both components' operators of a grid; `step(u, v, dt, nu, scheme)` -> (u, v), the
    periodic duplicates copied."""

    def __init__(self, grid: MacGrid):
        self.grid = grid
        self.ops = (ViscousOperator(grid, "u"), ViscousOperator(grid, "v"))

    def step(self, u, v, dt, nu, scheme="implicit"):
        if nu == 0.0:
            return np.array(u, float), np.array(v, float)
        un, vn = (op.step(a, dt, nu, scheme) for op, a in zip(self.ops, (u, v)))
        if self.grid.periodic[0]:
            un[-1] = un[0]
        if self.grid.periodic[1]:
            vn[:, -1] = vn[:, 0]
        return un, vn

    @staticmethod
    def describe(scheme: str) -> dict:
        return {"scheme": scheme, "text": "backward Euler, SuperLU of (I - dt nu M) "
                "factorised once per dt" if scheme == "implicit" else
                "forward Euler (stable for nu dt / h^2 <= 1/4)",
                "operator": "5-point Laplacian per face component, no-slip ghosts "
                            "2 w - u at walls (w: the lid for u at the top, else 0)",
                "order_dt": 1, "order_h": 2}
