"""The viscous step on the MAC faces: a Fourier mode decays by the exact discrete factor
(implicit 1 / (1 + dt nu lambda), explicit 1 - dt nu lambda), Couette flow under a lid is
a steady state of the discrete operator, wall faces stay fixed."""
import numpy as np
import pytest

from refsim.models.grid_fluid.mac import MacGrid
from refsim.models.grid_fluid.viscosity import Viscosity

EPS = np.finfo(float).eps


def _mode(n=16):
    """u = sin(kx x) cos(ky y) on the periodic unit box (kx = 2 pi, ky = 4 pi), v = 0."""
    grid = MacGrid(n, n, 1.0 / n, (True, True))
    pts = grid.u_points()
    u = np.sin(2 * np.pi * pts[..., 0]) * np.cos(4 * np.pi * pts[..., 1])
    u[-1] = u[0]
    lam = 4 / grid.h ** 2 * (np.sin(np.pi * grid.h) ** 2 + np.sin(2 * np.pi * grid.h) ** 2)
    return grid, u, np.zeros((n, n + 1)), lam


@pytest.mark.parametrize("scheme", ["implicit", "explicit"])
def test_a_fourier_mode_decays_by_the_exact_discrete_factor(scheme):
    grid, u, v, lam = _mode()
    dt, nu = 0.01, 0.05
    un, vn = Viscosity(grid).step(u, v, dt, nu, scheme)
    factor = 1 / (1 + dt * nu * lam) if scheme == "implicit" else 1 - dt * nu * lam
    # the mode is an eigenvector of M: the step's rounding only, a few eps relative to |u|
    # (the LU solve's backward error: ~ 10 eps cond(I + dt nu M) with cond < 2 here)
    assert np.max(np.abs(un - factor * u)) <= 64 * EPS
    assert np.array_equal(vn, v) and np.array_equal(un[-1], un[0])
    # nu 0.1 % off changes the factor by ~ 1e-3 dt nu lam / (1 + dt nu lam) = 3e-5 here,
    # 1e11 x the bound above: this test catches it
    assert abs(factor - 1) * 1e-3 > 1e4 * 64 * EPS


def test_couette_flow_is_a_steady_state_of_the_viscous_operator():
    """u = lid (j + 1/2) / ny, linear in y: the no-slip ghosts continue the line, so
    lap u = 0 exactly up to rounding and the implicit step returns it."""
    n = 8
    grid = MacGrid(n, n, 1.0 / n, (True, False), lid=1.5)
    y = (np.arange(n) + 0.5) / n
    u = np.tile(1.5 * y, (n + 1, 1))
    v = np.zeros((n, n + 1))
    visc = Viscosity(grid)
    lap = visc.ops[0].apply(u)
    # each row sums ~4 values of size <= 1.5 over h^2: a few eps x 1.5 / h^2
    assert np.max(np.abs(lap)) <= 16 * EPS * 1.5 / grid.h ** 2
    un, vn = visc.step(u, v, 0.1, 0.3, "implicit")
    assert np.max(np.abs(un - u)) <= 1e-14


def test_wall_faces_stay_zero_and_the_lid_drags_the_top_row():
    n = 6
    grid = MacGrid(n, n, 1.0 / n, lid=1.0)
    visc = Viscosity(grid)
    u, v = np.zeros((n + 1, n)), np.zeros((n, n + 1))
    un, vn = visc.step(u, v, 0.01, 0.1, "implicit")
    assert np.all(un[[0, -1]] == 0) and np.all(vn == 0)
    assert np.all(un[1:-1, -1] > 0) and np.all(un[1:-1, -1] > un[1:-1, -2])
    ue, _ = visc.step(u, v, 0.01, 0.1, "explicit")
    # explicit: only the top row moves, by dt nu 2 lid / h^2
    assert np.allclose(ue[1:-1, -1], 0.01 * 0.1 * 2 / grid.h ** 2, rtol=1e-14)
    assert np.all(ue[:, :-1] == 0)


def test_unknown_scheme_is_refused():
    grid, u, v, _ = _mode(4)
    with pytest.raises(ValueError, match="viscosity scheme must be one of"):
        Viscosity(grid).step(u, v, 0.1, 0.1, "crank_nicolson")
