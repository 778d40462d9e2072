"""taichi's Poisson group (cg, mgpcg) against exact discrete solutions of L_h u = f.

Error bound used throughout: on the free points L_h (u - u_h) = -(f - L_h u) = -r with
u - u_h = 0 on the boundary, so ||u - u_h||_2 <= ||r||_2 / lam_min, lam_min = sum_k (4 / h^2)
sin^2(pi h / 2) the smallest eigenvalue of -L_h (d (4 / h^2) sin^2(pi h / 2) on a cube).
r is recomputed here in numpy from the observed u: its round-off, per entry at most
gamma_{2d+2} (|f| + |L_h| |u|) (2d + 1 stencil terms and f, gamma_n = n eps / (1 - n eps)),
is added to ||r||; the oracle's own round-off ((d + 3) eps |u_h|: d sines, a product, a
factor) is added to the error.
"""

import numpy as np
import pytest

from refsim import registry
from refsim.models.grid_laplacian import GridLaplacian
from refsim.scene import Grid, Scene

pytest.importorskip("taichi")
from refsim_adapters.taichi_engine.groups.grid_poisson import (
    MultigridOptions,
    PoissonSim,
    iteration_cap,
    level_shapes,
    multigrid_reason,
)

CPU_ARCHS = ("x64", "arm64")  # ti.cpu is taichi's x86-64 or aarch64 backend

EPS = np.finfo(float).eps
RTOL = 1e-8


def shape_of(n, d):
    """(n,) * d, or n itself when it is already a shape."""
    return tuple(n) if isinstance(n, tuple) else (n,) * d


def coordinates(n, d):
    """The unit square / cube sampled by a grid of shape_of(n, d) points (h_k = 1/(n_k - 1))."""
    return np.meshgrid(*[np.linspace(0.0, 1.0, m) for m in shape_of(n, d)], indexing="ij")


def sine_problem(n, d):
    """u = prod sin(pi x_k): f = -d pi^2 u, u_h = [pi^2 h^2 / (4 sin^2(pi h / 2))] u."""
    h = 1.0 / (n - 1)
    mode = np.prod([np.sin(np.pi * x) for x in coordinates(n, d)], axis=0)
    return -d * np.pi ** 2 * mode, np.pi ** 2 * h ** 2 / (4 * np.sin(np.pi * h / 2) ** 2) * mode


def polynomial_problem(n, d, boundary=True):
    """u = prod x_k (1 - x_k) (+ 1 + x_0 + 2 x_1 + 3 x_0 x_1 with `boundary`): quadratic along
    every axis, so the 3-point second difference is exact and u_h = u; the multilinear part is
    harmonic for L_h (its second differences vanish) and sets nonzero Dirichlet values.
    f = L_h u = -2 sum_k prod_{j != k} x_j (1 - x_j): every odd mode is present in f (unlike
    the sine). Without `boundary`, u is 0 on the boundary and the initial residual is f."""
    xs = coordinates(n, d)
    bumps = [x * (1 - x) for x in xs]
    u = np.prod(bumps, axis=0)
    if boundary:
        u = u + 1 + xs[0] + 2 * xs[1] + 3 * xs[0] * xs[1]
    f = -2 * sum(np.prod([bumps[j] for j in range(d) if j != k], axis=0) for k in range(d))
    return f, u


def poisson_scene(f, boundary_values=None, rtol=RTOL):
    d = f.ndim
    guess = np.zeros_like(f)
    if boundary_values is not None:
        inner = (slice(1, -1),) * d
        guess = boundary_values.copy()
        guess[inner] = 0.0
    grid = Grid(shape=f.shape, spacing=[1.0 / (m - 1) for m in f.shape], model="poisson", boundary="dirichlet",
                fields={"u": guess, "f": f}, coefficients={"rtol": rtol})
    return Scene(parts=(grid,), gravity=(0, 0, 0))


def solve(scene, variant, options=None):
    if options is None:
        sim = registry.get_engine("taichi").build(scene, 1.0, "steady", variant)
    else:
        sim = PoissonSim(scene.part(Grid), variant, options)
    sim.step(1)
    assert sim.failure is None
    return sim, sim.observe()


def error_bound(u, f, exact):
    """(||u - u_h||_2, the bound above, numpy's relative residual, its round-off share)."""
    d = f.ndim
    h = np.array([1.0 / (m - 1) for m in f.shape])
    lap = GridLaplacian(f.shape, h, (("dirichlet", "dirichlet"),) * d)
    free = lap.free
    r = np.where(free, f - lap.apply(u), 0.0)
    gamma = (2 * d + 2) * EPS / (1 - (2 * d + 2) * EPS)
    rounding = gamma * np.linalg.norm(np.where(free, np.abs(f) + _abs_stencil(u, h), 0.0))
    lam_min = float(np.sum(4 / h ** 2 * np.sin(np.pi * h / 2) ** 2))
    error = np.linalg.norm(u - exact)
    bound = (np.linalg.norm(r) + rounding) / lam_min + (d + 3) * EPS * np.linalg.norm(exact)
    f_norm = np.linalg.norm(f[free])
    return error, bound, np.linalg.norm(r) / f_norm, rounding / f_norm


def _abs_stencil(u, h):
    """|L_h| |u| at every point (the sum of the stencil terms' magnitudes)."""
    a = np.abs(u)
    out = np.zeros_like(a)
    for k in range(a.ndim):
        out = out + (2 * a + np.roll(a, 1, k) + np.roll(a, -1, k)) / h[k] ** 2
    return out


@pytest.mark.parametrize("variant", ["cg", "mgpcg"])
@pytest.mark.parametrize("d, n", [(2, 33), (3, 17)])
def test_sine_mode_matches_the_exact_discrete_solution(variant, d, n):
    """||u - u_h|| within ||r|| / lam_min; the reported and the recomputed residual <= rtol.
    CG needs exactly one iteration: f is an eigenvector of L_h, so r_0 = -f spans the Krylov
    space and the first step is exact (to round-off)."""
    f, exact = sine_problem(n, d)
    _sim, obs = solve(poisson_scene(f), variant)
    error, bound, residual, rounding = error_bound(obs["grid.u"], f, exact)
    assert error <= bound
    assert obs["residual"] <= RTOL and residual <= RTOL + rounding
    assert np.array_equal(obs["grid.f"], f)
    if variant == "cg":
        assert obs["iterations"] == 1


@pytest.mark.parametrize("variant", ["cg", "mgpcg"])
@pytest.mark.parametrize("d, n", [(2, 33), (3, 17)])
def test_polynomial_with_dirichlet_values_matches_exactly(variant, d, n):
    f, exact = polynomial_problem(n, d)
    _sim, obs = solve(poisson_scene(f, boundary_values=exact), variant)
    error, bound, residual, rounding = error_bound(obs["grid.u"], f, exact)
    assert error <= bound
    assert obs["residual"] <= RTOL and residual <= RTOL + rounding
    boundary = ~GridLaplacian.of(sim_grid(f, exact)).free
    assert np.array_equal(obs["grid.u"][boundary], exact[boundary])  # Dirichlet values kept


@pytest.mark.parametrize("variant", ["cg", "mgpcg"])
@pytest.mark.parametrize("shape", [(33, 17), (9, 17, 5)])
def test_rectangular_grids_with_unequal_spacing(variant, shape):
    """2^k + 1 points per axis with different k (the hierarchy halves every axis until the
    shortest has 3 points) and h_k = 1 / (n_k - 1): the polynomial oracle still holds exactly;
    lam_min = sum_k (4 / h_k^2) sin^2(pi h_k / 2)."""
    f, exact = polynomial_problem(shape, len(shape))
    _sim, obs = solve(poisson_scene(f, boundary_values=exact), variant)
    error, bound, residual, rounding = error_bound(obs["grid.u"], f, exact)
    assert error <= bound and obs["residual"] <= RTOL and residual <= RTOL + rounding


def sim_grid(f, exact):
    return poisson_scene(f, boundary_values=exact).part(Grid)


OPTIONS = [MultigridOptions(smoother="jacobi"), MultigridOptions(cycle="W"),
           MultigridOptions(sweeps=2), MultigridOptions(levels=2),
           MultigridOptions(smoother="jacobi", cycle="W", sweeps=3, levels=3)]


@pytest.mark.parametrize("options", OPTIONS, ids=lambda o: f"{o.smoother}-{o.cycle}-"
                         f"{o.sweeps}-{o.levels}")
def test_every_multigrid_option_converges_to_the_oracle(options):
    f, exact = polynomial_problem(33, 2)
    sim, obs = solve(poisson_scene(f, boundary_values=exact), "mgpcg", options)
    error, bound, residual, rounding = error_bound(obs["grid.u"], f, exact)
    assert error <= bound and obs["residual"] <= RTOL and residual <= RTOL + rounding
    assert sim.settings()["multigrid"]["smoother"] == options.smoother


@pytest.mark.parametrize("d, sizes", [(2, (33, 65, 129, 257)), (3, (17, 33, 65))])
def test_mgpcg_iterations_stay_bounded_as_the_grid_doubles(d, sizes):
    """Multigrid's contraction factor does not depend on h, so with the same reduction asked
    of ||r_0|| (zero boundary values: r_0 = -f, the target rtol ||f||) the count varies only
    by the rounding of ln(rtol) / ln(rho): at most 1 over the sizes (CG's own count doubles
    with each doubling, next test). With nonzero boundary values ||r_0|| / ||f|| grows like
    h^-5/2 (boundary data / h^2 next to the boundary) and the count by its logarithm."""
    counts = []
    for n in sizes:
        f, _exact = polynomial_problem(n, d, boundary=False)
        counts.append(solve(poisson_scene(f), "mgpcg")[1]["iterations"])
    assert max(counts) - min(counts) <= 1, counts


def test_cg_iterations_grow_like_n():
    """CG's count scales with sqrt(kappa) = cot(pi h / 2) ~ 2 / (pi h): slope 1 in N - 1 on a
    log-log fit (f with every mode present). The fitted slope is within 0.1 of 1: a count
    depending on sqrt(kappa) ln(sqrt(kappa)/rtol) (the bound) would give 1 + 1/ln(...) <= 1.1
    at these sizes; every count is under the bound (iteration_cap / 2)."""
    sizes, counts = (33, 65, 129, 257), []
    for n in sizes:
        f, _exact = polynomial_problem(n, 2, boundary=False)
        sim, obs = solve(poisson_scene(f), "cg")
        counts.append(obs["iterations"])
        assert obs["iterations"] <= sim.cap
    slope = np.polyfit(np.log(np.array(sizes) - 1.0), np.log(counts), 1)[0]
    assert abs(slope - 1.0) <= 0.1, (counts, slope)


def precondition(sim, r):
    """z = M r by the Sim's multigrid cycle (r zero on the boundary)."""
    sim.solver.r.from_numpy(np.ascontiguousarray(r))
    sim.solver.multigrid.apply()
    return sim.solver.z.to_numpy()


@pytest.mark.parametrize("options", OPTIONS + [MultigridOptions()],
                         ids=lambda o: f"{o.smoother}-{o.cycle}-{o.sweeps}-{o.levels}")
@pytest.mark.parametrize("d, n", [(2, 17), (3, 9)])
def test_the_multigrid_preconditioner_is_symmetric_positive_definite(options, d, n):
    """<M a, b> = <a, M b> (post-smoother the adjoint of the pre-smoother, restriction =
    P^T / 2^d, symmetric coarse solve: what CG needs) and <a, M a> > 0. Round-off: each of the
    `passes` kernel passes over a point adds at most (2d + 2) eps relative to the magnitudes
    it combines, which the cycle does not amplify beyond ||M|| (smoothers contract, transfer
    weights sum to <= 1); so |<Ma, b> - <a, Mb>| <= 2 passes (2d + 2) eps ||M|| ||a|| ||b||
    with ||M|| <= max ||M r|| / ||r|| over the samples (an estimate from below, hence the
    factor 2 on the count of passes, each counted once per level visit)."""
    f, _ = sine_problem(n, d)
    sim = PoissonSim(poisson_scene(f).part(Grid), "mgpcg", options)
    opts = sim.options
    visits = opts.levels if opts.cycle == "V" else 2 ** opts.levels
    passes = visits * (4 * opts.sweeps + 4) + 4 * opts.coarse_sweeps * visits
    free = GridLaplacian.of(sim_grid(f, f)).free
    rng = np.random.default_rng(7)
    a, b = (np.where(free, rng.standard_normal(f.shape), 0.0) for _ in range(2))
    ma, mb = precondition(sim, a), precondition(sim, b)
    norm_m = max(np.linalg.norm(ma) / np.linalg.norm(a), np.linalg.norm(mb) / np.linalg.norm(b))
    bound = 2 * passes * (2 * d + 2) * EPS * norm_m * np.linalg.norm(a) * np.linalg.norm(b)
    assert abs(np.vdot(ma, b) - np.vdot(a, mb)) <= bound
    assert np.vdot(a, ma) > 0 and np.vdot(b, mb) > 0


def test_each_step_re_solves_from_the_initial_guess():
    f, exact = polynomial_problem(17, 2)
    scene = poisson_scene(f, boundary_values=exact)
    engine = registry.get_engine("taichi")
    once, twice = (engine.build(scene, 1.0, "steady", "mgpcg") for _ in range(2))
    start = once.observe()
    assert start["iterations"] == 0 and start["residual"] > RTOL
    once.step(1)
    twice.step(2)
    a, b = once.observe(), twice.observe()
    assert a["iterations"] == b["iterations"] > 0
    # same operations: the same solve from the same initial guess, serial kernels
    assert np.array_equal(a["grid.u"], b["grid.u"]) and b["t"] == 2.0


def test_settings_report_the_contract_and_every_option():
    f, _ = sine_problem(33, 2)
    scene = poisson_scene(f)
    engine = registry.get_engine("taichi")
    assert engine.formulations(scene) == ("cg", "mgpcg")
    assert engine.offered_integrators(scene) == ("steady",)
    sim = engine.build(scene, 1.0, "steady", "mgpcg")
    settings = sim.settings()
    assert settings["integrator"] == {"name": "steady", "order": 0, "family": "static solve",
                                      "explicit": False, "symplectic": False}
    assert settings["dtype"] == "float64" and settings["rtol"] == RTOL
    assert settings["arch"] in CPU_ARCHS and settings["threads"] >= 1
    mg = settings["multigrid"]
    assert mg["levels"] == 5 and mg["level_shapes"][-1] == [3, 3]
    assert {"smoother", "sweeps", "cycle", "coarse_sweeps"} <= set(mg)
    assert "multigrid" not in engine.build(scene, 1.0, "steady", "cg").settings()


def test_refusals_name_the_reason():
    engine = registry.get_engine("taichi")
    f = np.zeros((20, 20))
    odd = poisson_scene(f)
    assert engine.formulations(odd) == ("cg",)
    assert "2^k + 1" in multigrid_reason((20, 20))
    with pytest.raises(ValueError, match="2\\^k \\+ 1"):
        PoissonSim(odd.part(Grid), "mgpcg")
    assert "integrator" in engine.supports(odd, "rk4")
    neumann = Scene(parts=(Grid((9, 9), 0.125, "poisson", {"u": np.zeros((9, 9)),
                                                          "f": np.ones((9, 9))},
                                boundary="neumann", coefficients={"rtol": 1e-6}),),
                    gravity=(0, 0, 0))
    assert "Dirichlet" in engine.supports(neumann, "steady")
    no_rtol = Scene(parts=(Grid((9, 9), 0.125, "poisson", {"u": np.zeros((9, 9)),
                                                          "f": np.ones((9, 9))}),),
                    gravity=(0, 0, 0))
    assert "rtol" in engine.supports(no_rtol, "steady")
    line = Scene(parts=(Grid((9,), 0.125, "poisson", {"u": np.zeros(9), "f": np.ones(9)},
                             coefficients={"rtol": 1e-6}),), gravity=(0, 0, 0))
    assert "2D or 3D" in engine.supports(line, "steady")


@pytest.mark.parametrize("bad, match", [({"sweeps": 0}, "sweeps"), ({"smoother": "sor"},
                                        "smoother"), ({"cycle": "F"}, "cycle"),
                                        ({"levels": -1}, "levels")])
def test_bad_multigrid_options_are_refused(bad, match):
    with pytest.raises(ValueError, match=match):
        MultigridOptions(**bad)


def test_too_many_levels_are_refused():
    with pytest.raises(ValueError, match="levels must be in \\[1, 4\\]"):
        MultigridOptions(levels=5).resolved((17, 17))
    assert level_shapes((17, 33), 0) == [(17, 33), (9, 17), (5, 9), (3, 5)]


def test_a_target_below_round_off_is_a_failure_not_a_result():
    """rtol 1e-15 at h = 1/32: the residual's own rounding, about eps 8 |u| / h^2 per point
    against |f| ~ 2 pi^2 |u|, is ~1e-13 of ||f||: unreachable; the Sim fails with the reason
    after the iteration cap (twice CG's bound), never reports an unconverged u as solved."""
    f, _exact = polynomial_problem(33, 2, boundary=False)
    sim = registry.get_engine("taichi").build(poisson_scene(f, rtol=1e-15), 1.0, "steady", "cg")
    sim.step(1)
    assert sim.failure is not None and "round-off" in sim.failure
    assert sim.cap == iteration_cap((33, 33), (1 / 32, 1 / 32), 1e-15)
