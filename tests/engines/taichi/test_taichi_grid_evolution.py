"""taichi's finite-difference group (heat and wave equations on 1D/2D/3D grids): the same
arithmetic as refsim's grid_evolution group to round-off, the exact discrete solutions of a
Fourier mode, leapfrog exact at Courant number 1, refusals with reasons, settings.

Round-off bounds (stated once, used throughout): one step of any scheme here is a chain of at
most K = 16 roundings per point (the 3-point difference per axis, its sum over <= 3 axes, the
coefficient and step products, RK4's four stages; an LU solve of the diagonally dominant
I - c h^k L, condition <= 1 + c h^k rho <= 2 at the dts used, adds a backward error of the same
order). Every dt below lies inside its scheme's stability region, so the step is
non-expansive and the errors of k steps add: |difference| <= k K eps S, S the largest |value|.
For the wave equation a round-off dx in u becomes a change of at most c sqrt(rho) dx in v
(the discrete energy |v|^2 + c^2 |grad_h u|^2 is conserved to O(h) and |grad_h u| <=
sqrt(rho) |u|), so the v bound carries S_v + c sqrt(rho) S_u. rho = sum 4 / h^2 bounds |L|.
"""
import numpy as np
import pytest

from refsim_adapters.common.grid_pde import DIFFUSION_INTEGRATORS, WAVE_INTEGRATORS
from refsim import registry
from refsim.integrators.first_order import get_first_order
from refsim.integrators.sparse_linear import first_order_implicit
from refsim.models.grid_laplacian import GridLaplacian, mode_eigenvalue
from refsim.scene import Scene
from refsim.scene.grids import Grid

pytest.importorskip("taichi")
EPS = np.finfo(float).eps
K = 16  # roundings per point per step at most (module docstring)
TAICHI, REFSIM = registry.get_engine("taichi"), registry.get_engine("refsim")
SHAPES = {1: (11,), 2: (7, 6), 3: (5, 4, 6)}
BOUNDARIES = {"dirichlet": "dirichlet", "neumann": "neumann", "periodic": "periodic",
              "mixed": lambda nd: (("dirichlet", "neumann"),) + (("periodic",) * 2,) * (nd - 1)}


def grid_scene(model, shape, boundary, fields, spacing=0.1, coefficient=None):
    name = "diffusivity" if model == "diffusion" else "wave_speed"
    grid = Grid(shape=shape, spacing=spacing, model=model, fields=fields, boundary=boundary,
                coefficients={name: coefficient or (0.7 if model == "diffusion" else 1.3)})
    return Scene(parts=(grid,), gravity=(0, 0, 0))


def rho(scene):
    return GridLaplacian.of(scene.part(Grid)).spectral_radius_bound()


def stable_dt(model, scene):
    """Half the explicit limit (heat: D dt rho <= 2 for FTCS, 2.78 for RK4 (the smallest of
    the offered, midpoint/heun 2); wave: c dt sqrt(rho) <= 2 for leapfrog, 2.83 RK4): 0.4/(D rho)
    resp. 0.8/(c sqrt rho), inside every explicit scheme's interval (RK4's on the imaginary
    axis for the wave is wider than 0.8)."""
    coef = scene.part(Grid).coefficients
    if model == "diffusion":
        return 0.4 / (coef["diffusivity"] * rho(scene))
    return 0.8 / (coef["wave_speed"] * np.sqrt(rho(scene)))


def run(engine, scene, dt, integrator, chunks):
    sim = engine.build(scene, dt, integrator, "")
    for n in chunks:
        sim.step(n)
    return sim.observe()


@pytest.mark.parametrize("boundary", list(BOUNDARIES))
@pytest.mark.parametrize("integrator", DIFFUSION_INTEGRATORS)
def test_heat_taichi_matches_refsim(integrator, boundary):
    """Every heat scheme, 1D/2D/3D: |taichi - refsim| <= k K eps S (module docstring); the
    steps in uneven chunks (FTCS's two buffers swapped on odd counts)."""
    rng = np.random.default_rng(3)
    for nd, shape in SHAPES.items():
        kind = BOUNDARIES[boundary]
        scene = grid_scene("diffusion", shape, kind(nd) if callable(kind) else kind,
                           {"T": rng.uniform(-1, 1, shape)})
        dt, chunks = stable_dt("diffusion", scene), (7, 6)
        a, b = (run(e, scene, dt, integrator, chunks)["grid.T"] for e in (TAICHI, REFSIM))
        assert a.shape == shape
        assert np.max(np.abs(a - b)) <= sum(chunks) * K * EPS * 1.0, (nd, integrator)


@pytest.mark.parametrize("boundary", list(BOUNDARIES))
@pytest.mark.parametrize("integrator", WAVE_INTEGRATORS)
def test_wave_taichi_matches_refsim(integrator, boundary):
    """Every wave scheme, 1D/2D/3D: u within k K eps S_u, v within k K eps (S_v + c sqrt(rho)
    S_u) (module docstring)."""
    rng = np.random.default_rng(4)
    for nd, shape in SHAPES.items():
        kind = BOUNDARIES[boundary]
        scene = grid_scene("wave", shape, kind(nd) if callable(kind) else kind,
                           {"u": rng.uniform(-1, 1, shape), "v": rng.uniform(-1, 1, shape)})
        dt, chunks = stable_dt("wave", scene), (5, 8)
        a, b = (run(e, scene, dt, integrator, chunks) for e in (TAICHI, REFSIM))
        k, c = sum(chunks), scene.part(Grid).coefficients["wave_speed"]
        assert np.max(np.abs(a["grid.u"] - b["grid.u"])) <= k * K * EPS * 1.0
        assert np.max(np.abs(a["grid.v"] - b["grid.v"])) <= \
            k * K * EPS * (1.0 + c * np.sqrt(rho(scene)))


def heat_mode(shape, spacing, boundary):
    """A product eigenvector of L and its eigenvalue (refsim.models.grid_laplacian)."""
    u, lam = np.ones(()), 0.0
    for n in shape:
        j = np.arange(n)
        if boundary == "dirichlet":
            theta, axis_mode = 2 * np.pi / (n - 1), np.sin(2 * np.pi * j / (n - 1))
        elif boundary == "neumann":
            theta, axis_mode = np.pi / (n - 1), np.cos(np.pi * j / (n - 1))
        else:
            theta, axis_mode = 2 * np.pi / n, np.cos(2 * np.pi * j / n)
        u = np.multiply.outer(u, axis_mode)
        lam += mode_eigenvalue(theta, spacing)
    return u, lam


@pytest.mark.parametrize("boundary, nd", [("dirichlet", 2), ("periodic", 1), ("neumann", 3)])
@pytest.mark.parametrize("integrator", DIFFUSION_INTEGRATORS)
def test_heat_fourier_mode_amplification_exact(integrator, boundary, nd):
    """u_n = R(dt D lambda)^n u_0 for an eigenmode, R the scheme's stability function (FTCS
    1 + z, implicit Euler 1/(1 - z), Crank-Nicolson (1 + z/2)/(1 - z/2), the RK polynomials):
    within n K eps max|u_0| (module docstring)."""
    shape, h, diffusivity, n = {1: (16,), 2: (17, 13), 3: (9, 7, 5)}[nd], 0.05, 0.3, 25
    u0, lam = heat_mode(shape, h, boundary)
    scene = grid_scene("diffusion", shape, boundary, {"u": u0}, spacing=h,
                       coefficient=diffusivity)
    dt = stable_dt("diffusion", scene)
    stepper = first_order_implicit(integrator) if integrator in ("implicit_euler",
                                                                 "crank_nicolson") \
        else get_first_order(integrator)
    gain = stepper.stability(dt * diffusivity * lam).real
    got = run(TAICHI, scene, dt, integrator, (n,))["grid.u"]
    assert abs(gain) < 1.0  # a decaying mode: the test is not of a constant
    assert np.max(np.abs(got - gain ** n * u0)) <= n * K * EPS * 1.0


def test_leapfrog_exact_at_courant_one():
    """1D Dirichlet, c dt = h: the leapfrog's dispersion relation sin(w dt/2) = C sin(theta/2)
    gives w dt = theta, and the Taylor start makes u_1 = cos(theta) u_0, so u_n = cos(n theta)
    u_0 exactly; theta = 2 pi k/(2 (N-1)) with k = 2 returns after 2 (N-1)/k = 32 steps.
    Bound n^2 K eps: at C = 1 the sawtooth mode's amplification root -1 is double, so an error
    may grow linearly per step there (sum over n steps of n K eps)."""
    n_points, h, c, k = 33, 1.0 / 32, 2.0, 2
    x = np.arange(n_points) * h
    u0 = np.sin(k * np.pi * x)
    scene = grid_scene("wave", (n_points,), "dirichlet", {"u": u0}, spacing=h, coefficient=c)
    dt, theta = h / c, k * np.pi * h
    sim = TAICHI.build(scene, dt, "stormer_verlet", "")
    for n in range(1, 33):
        sim.step(1)
        got = sim.observe()["grid.u"]
        assert np.max(np.abs(got - np.cos(n * theta) * u0)) <= n * n * K * EPS
    assert np.max(np.abs(got - u0)) <= 32 * 32 * K * EPS  # one period: back where it began


def test_refusals_give_reasons():
    shape = (5, 5)
    heat = grid_scene("diffusion", shape, "dirichlet", {"u": np.zeros(shape)})
    wave = grid_scene("wave", shape, "dirichlet", {"u": np.zeros(shape)})
    assert "first order" in TAICHI.supports(heat, "symplectic_euler")
    assert "implicit_midpoint" in TAICHI.supports(wave, "crank_nicolson")
    assert "offers no integrator" in TAICHI.supports(heat, "dopri5_adaptive")
    assert "must be one of" in TAICHI.supports(wave, "explicit_euler")
    assert "first order" in TAICHI.supports(heat, "stormer_verlet")
    other = grid_scene("diffusion", shape, "dirichlet", {"w": np.zeros(shape)}).part(Grid)
    two = Scene(parts=(heat.part(Grid), other), gravity=(0, 0, 0))
    assert "one grid per scene" in TAICHI.supports(two, "explicit_euler")
    bad = Grid(shape=shape, spacing=0.1, model="diffusion", fields={"u": np.zeros(shape)},
               coefficients={"diffusivity": -1.0})
    assert "diffusivity" in TAICHI.supports(Scene(parts=(bad,), gravity=(0, 0, 0)), "rk4")
    with pytest.raises(ValueError, match="first order"):
        TAICHI.build(heat, 0.01, "velocity_verlet", "")


@pytest.mark.parametrize("integrator", ["explicit_euler", "crank_nicolson"])
def test_heat_settings_and_observation(integrator):
    shape = (6, 5)
    scene = grid_scene("diffusion", shape, "neumann", {"c": np.ones(shape)})
    sim = TAICHI.build(scene, 1e-3, integrator, "")
    settings = sim.settings()
    assert settings["dtype"] == "float64" and settings["default_fp"].endswith("f64")
    assert settings["integrator"]["name"] == integrator and settings["points"] == 30
    assert settings["threads"] == settings["cpu_max_num_threads"]
    assert ("SparseSolver" in settings["solve"]) == (integrator == "crank_nicolson")
    first = sim.observe()["grid.c"]
    first[...] = 7.0  # a copy: the state is untouched
    sim.step(3)
    assert np.allclose(sim.observe()["grid.c"], 1.0, rtol=0, atol=3 * K * EPS)


def test_wave_observes_u_and_v_of_the_grid_shape():
    shape = (4, 5, 6)
    scene = grid_scene("wave", shape, "periodic", {"u": np.ones(shape)})
    sim = TAICHI.build(scene, 1e-3, "implicit_midpoint", "")
    sim.step(2)
    seen = sim.observe()
    assert set(seen) == {"t", "grid.u", "grid.v"}
    assert seen["grid.u"].shape == seen["grid.v"].shape == shape
    assert sim.settings()["integrator"] == {"name": "implicit_midpoint", "order": 2,
                                            "family": "implicit midpoint (taichi "
                                                      "SparseSolver LU)",
                                            "explicit": False, "symplectic": True}
