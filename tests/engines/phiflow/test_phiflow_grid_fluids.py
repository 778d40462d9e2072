"""The PhiFlow peer on the grid fluids (adapters/phiflow_engine): float64 taken, the face layout
mapped both ways, the lid on the right wall with its sign and PhiFlow's ghost value, the
projection's divergence within its tolerance, and Taylor-Green's decay against the bilinear
semi-Lagrangian theory. Skipped when phiflow is not installed (it is an optional peer:
`pip install -e ".[peers]"`).

Cost (measured on the shared 2-core machine): importing phi ~0.7-1.6 s once per process; one
step at 8^2-16^2 0.3-0.7 s of CPU (PhiFlow's Python overhead, not the grid): tests that step
more than once are marked slow."""
from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("phi", reason="phiflow is an optional peer (extra 'peers')")

from refsim.registry import get_case  # noqa: E402
from refsim.scene import FluidGrid, Scene  # noqa: E402
from refsim_adapters.phiflow_engine import PhiflowEngine  # noqa: E402
from refsim_adapters.phiflow_engine import staggered  # noqa: E402


def _cavity(n=8, lid=1.0, nu=0.01, rtol=1e-10):
    part = FluidGrid(n, n, 1.0 / n, np.zeros((n + 1, n)), np.zeros((n, n + 1)), sides="wall",
                     nu=nu, lid=lid, rtol=rtol)
    return Scene(parts=(part,), dim=2)


def _random_faces(rng, n, periodic):
    u, v = rng.standard_normal((n + 1, n)), rng.standard_normal((n, n + 1))
    if periodic:
        u[-1], v[:, -1] = u[0], v[:, 0]
    else:
        u[0] = u[-1] = 0.0
        v[:, 0] = v[:, -1] = 0.0
    return u, v


@pytest.mark.parametrize("sides", ["wall", "periodic"])
def test_layout_round_trips_and_keeps_positions(sides):
    """refsim's (u, v) -> PhiFlow's StaggeredGrid -> refsim's, bit for bit (a copy, no
    arithmetic); and the positions: PhiFlow sampling f = 10 x + y at its own faces gives
    refsim's f at (i h, (j + 1/2) h) and ((i + 1/2) h, j h) (h = 1), so the mapping neither
    transposes nor shifts (the wall faces are the boundary's, 0)."""
    from phi import math as pm
    from phi.flow import StaggeredGrid, vec, Box
    n, periodic = 4, sides == "periodic"
    u, v = _random_faces(np.random.default_rng(3), n, periodic)
    part = FluidGrid(n, n, 1.0, u, v, sides=sides)
    ext = staggered.boundary(part)
    with pm.precision(64):
        back = staggered.from_grid(staggered.to_grid(u, v, part, ext), part)
        sampled = StaggeredGrid(lambda x: vec(x=10 * x.vector["x"] + x.vector["y"],
                                              y=100 + 10 * x.vector["x"] + x.vector["y"]),
                                ext, x=n, y=n, bounds=Box(x=float(n), y=float(n)))
        su, sv = staggered.from_grid(sampled, part)
    assert np.array_equal(back[0], u) and np.array_equal(back[1], v)
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n), indexing="ij")
    expect_u = 10.0 * i + (j + 0.5)
    k, m = np.meshgrid(np.arange(n), np.arange(n + 1), indexing="ij")
    expect_v = 100 + 10.0 * (k + 0.5) + m
    if periodic:  # the last face is the first one's copy
        expect_u[-1], expect_v[:, -1] = expect_u[0], expect_v[:, 0]
    else:
        expect_u[[0, -1]] = 0.0
        expect_v[:, [0, -1]] = 0.0
    # PhiFlow computes its face coordinates by its own arithmetic (measured: x off by up to an
    # ulp, 10 x by ~1e-16 relative); a transposition or a half-cell shift moves f by >= 0.5
    np.testing.assert_allclose(su, expect_u, rtol=4 * np.finfo(float).eps, atol=0)
    np.testing.assert_allclose(sv, expect_v, rtol=4 * np.finfo(float).eps, atol=0)


@pytest.mark.slow  # one PhiFlow step: 0.5-1 s of CPU, 3-5 s wall at load 10
def test_float64_taken_and_reported():
    """The field is float64 inside PhiFlow after a step, the observations too, and the
    settings say so (phi.math.precision(64) around every PhiFlow call)."""
    sim = PhiflowEngine().build(_cavity(), 0.05, "phi_semi_lagrangian")
    sim.step(1)
    assert sim.failure is None
    assert (sim.grid.values.dtype.kind, sim.grid.values.dtype.bits) == (float, 64)
    obs = sim.observe()
    assert all(obs[k].dtype == np.float64 for k in ("grid.u", "grid.v", "grid.p"))
    settings = sim.settings()
    assert settings["dtype"] == "float64" and settings["backend"] == "numpy"


@pytest.mark.slow  # one PhiFlow step: 0.5-1 s of CPU, 3-5 s wall at load 10
@pytest.mark.parametrize("lid", [1.0, -0.7])
def test_lid_on_the_top_wall_with_its_sign_and_ghost_value(lid):
    """The lid is the top wall's (y+) tangential velocity: one explicit diffusion step from rest
    (PhiFlow's diffuse.explicit on the mapped boundary) moves the top row of u, and only it, by
    nu dt / h^2 x lid exactly: PhiFlow's constant extrapolation pads with the wall value itself
    (refsim's MAC ghost 2 U - u gives twice that; docs/engine_notes.md#phiflow). Compared to
    round-off: 0.1 x lid in one multiply-add of exact zeros and lid."""
    from phi import math as pm
    from phi.physics import diffuse
    n, nu, dt = 8, 0.01, 0.1 / (0.01 * 64)  # nu dt / h^2 = 0.1
    part = _cavity(n, lid).part(FluidGrid)
    with pm.precision(64):
        grid = staggered.to_grid(part.u, part.v, part, staggered.boundary(part))
        u, v = staggered.from_grid(diffuse.explicit(grid, nu, dt), part)
    expect = np.zeros_like(u)
    expect[1:-1, -1] = 0.1 * lid
    assert np.allclose(u, expect, rtol=4e-16 * 4, atol=0)  # a few ulp of 0.1 lid
    assert np.array_equal(v, np.zeros_like(v))
    # the whole step: the top row moves with the lid's sign, the bottom row barely
    sim = PhiflowEngine().build(_cavity(n, lid), dt, "phi_semi_lagrangian")
    sim.step(1)
    top, bottom = sim.u[1:-1, -1], sim.u[1:-1, 0]
    assert np.all(np.sign(top) == np.sign(lid)) and np.abs(top).max() > 10 * np.abs(bottom).max()


@pytest.mark.slow  # one PhiFlow step: 0.5-1 s of CPU, 3-5 s wall at load 10
@pytest.mark.parametrize("sides", ["wall", "periodic"])
def test_projection_divergence_within_its_tolerance(sides):
    """A random field (not divergence-free) stepped once with nu = 0 and a tiny dt (advection
    moves it by 1e-6 cells): the projected field's true relative residual ||D u||_2 /
    ||D u*||_2, by refsim's divergence, is within the part's rtol = 1e-8. PhiFlow's CG stops
    on its recursive residual <= rel_tol ||b||, which the true one follows to round-off:
    measured 4.7e-9 on walls (29 iterations) and 3e-16 periodic (12: the periodic 8^2
    Laplacian has few distinct eigenvalues, CG ends exact). A field left unprojected, or
    mapped to the wrong faces, has a residual of order 1."""
    n, periodic = 8, sides == "periodic"
    u, v = _random_faces(np.random.default_rng(5), n, periodic)
    part = FluidGrid(n, n, 1.0 / n, u, v, sides=sides, rtol=1e-8)
    sim = PhiflowEngine().build(Scene(parts=(part,), dim=2), 1e-7, "phi_semi_lagrangian")
    before = np.linalg.norm(staggered.divergence(u, v, part.h))
    sim.step(1)
    obs = sim.observe()
    assert sim.failure is None and obs["iterations"] > 0
    assert obs["residual"] <= 1e-8
    div = staggered.divergence(obs["grid.u"], obs["grid.v"], part.h)
    assert np.linalg.norm(div) <= 1e-8 * before  # the same, from the observed arrays


@pytest.mark.slow
def test_taylor_green_decay_matches_the_bilinear_theory():
    """Taylor-Green at 16^2, nu = 0.05, CFL 0.5, T = 1 (5 steps, ~3 s of CPU), implicit
    viscosity (PhiFlow's diffuse.implicit works on periodic axes): the energy decays as
    exp(-4 (nu + nu_num) t) with nu_num the case's theory for bilinear semi-Lagrangian
    advection (split U^2 dt / 8 + interpolation 0.225 U h - ..., refsim's sl_linear measures
    1.000 of it). Bound 3 %: measured 1.015 at CFL 0.5 and 0.984 at CFL 0.125 (PhiFlow's Euler
    backtrace and the theory's dropped O(h^2, dt^2) terms); nu x 1.1 / x 0.9 planted in the
    diffusion by hand gives 1.079 / 0.952: caught."""
    case = get_case("taylor_green")
    p = case.variant_params("default", {"n": 16, "cfl": 0.5, "t_end": 1.0})
    dt = case.reference_dt(p)
    sim = PhiflowEngine().build(case.scene(p), dt, "phi_semi_lagrangian")
    assert "diffuse.implicit" in sim.settings()["viscosity"]
    energy = lambda o: case.energy(p, {k: o[k][None] for k in ("grid.u", "grid.v")})[0]  # noqa
    e0 = energy(sim.observe())
    steps = round(p["t_end"] / dt)
    sim.step(steps)
    assert sim.failure is None
    rate = -math.log(energy(sim.observe()) / e0) / (2 * steps * dt)
    measured = (rate - 2 * p["nu"]) / 2
    predicted = case.predicted_viscosity(p, "linear", dt)
    assert abs(measured / predicted - 1) <= 0.03, (measured, predicted)


def test_refusals_name_their_reason():
    """Every other part kind is refused with the peer's sentence (the pendulum's particles);
    MacCormack is refused on the cavity's moving lid (PhiFlow 3.4.0 fails there) and offered on
    Taylor-Green's periodic grid; the one-projection scene is refused."""
    engine = PhiflowEngine()
    pendulum = get_case("pendulum")
    assert engine.supports(pendulum.scene(pendulum.variant_params("default", {}))) \
        .startswith("PhiFlow peer: runs only the grid-fluid cases")
    cavity, tg = get_case("cavity"), get_case("taylor_green")
    lid_scene = cavity.scene(cavity.variant_params("default", {}))
    assert "mac_cormack fails on a moving wall" in engine.supports(lid_scene, "phi_mac_cormack")
    assert engine.supports(lid_scene, "phi_semi_lagrangian") is None
    assert engine.supports(tg.scene(tg.variant_params("default", {})), "phi_mac_cormack") is None
    projection = get_case("projection_manufactured")
    assert "time stepping only" in engine.supports(
        projection.scene(projection.variant_params("walls", {})))
