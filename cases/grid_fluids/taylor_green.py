"""Taylor-Green vortex on a periodic MAC grid (issue 27, case 2): the decay exp(-2 nu k^2 t)
and each semi-Lagrangian scheme's numerical viscosity.

Periodic box [0, 2 pi]^2, k = 1, U = 1: u = sin x cos y F(t), v = -cos x sin y F(t),
F = exp(-2 nu k^2 t) (MODELS.md section 5; Taylor & Green 1937). It is a steady solution of
the Euler equations ((u.grad) u = -grad p, p = (cos 2x + cos 2y) / 4): only viscosity changes
it, so every advection error shows as excess dissipation (and some distortion of the mode).
The mode sampled on the MAC faces is discretely divergence-free (exactly, in exact
arithmetic) and an eigenvector of the viscous operator, eigenvalue -lambda_h = -(8 / h^2)
sin^2(h / 2): without advection the implicit viscous step would multiply it by exactly
1 / (1 + dt nu lambda_h).

Numerical viscosity (`nu_numerical`, m^2/s): the kinetic energy E (the sum of the squared
face velocities) decays at twice the amplitude's rate; nu_num = (-ln(E_T / E_0) / (2 T) -
2 nu k^2) / (2 k^2): the excess amplitude decay rate over exp(-2 nu k^2 t), over 2 k^2. Its
theory (`numerical_viscosity`), three parts:
- the viscous step's own: (ln(1 + dt nu lambda_h) / dt - 2 nu k^2) / (2 k^2) (implicit; the
  explicit step's -ln(1 - dt nu lambda_h)), the exact discrete decay's excess: ~ nu^2 dt k^2
  - nu k^2 h^2 / 12, small;
- the splitting: advecting through the frozen u^n for dt and then projecting loses, per step,
  2 dt^2 <u, s> of energy, s = [((u.grad) u).grad u + u_i u_j d_i d_j u] / 2 (the dt^2 term of
  u at the departure point; the dt term is a gradient, removed by the projection), and for
  Taylor-Green <u, s> / <u, u> = -1/4 k^2 U^2 (evaluated by quadrature): nu_split = U^2 dt / 8,
  first order in dt, independent of h, the interpolant and the backtrace (the backtrace's
  dt^2 term adds a.grad(|u|^2 / 2), whose mean vanishes here);
- the interpolant: bilinear interpolation at the fractional offset a of a step's departure
  point errs by -a (1 - a) h^2 f'' / 2 per axis, a diffusion nu_a = |u_a| (h - |u_a| dt) / 2
  along axis a (first-order upwind as dt -> 0); its energy-weighted mean over the mode gives
  nu_linear = 0.225 U h - 0.156 U^2 dt (`interpolation_viscosity`); Catmull-Rom's
  dissipation is O(h^3) (its amplitude error per step ~ (k h)^4 / dt), negligible beside
  nu_split here, and the clamp barely acts on this smooth mode (the clamped rows equal the
  plain cubic's to 4 digits).
The numerical viscosity falls with the amplitude A(t) (A^2 for the splitting, about A for the
bilinear part); the case integrates dA/dt = -2 k^2 (nu + nu_num(A)) A for the theory's value
as measured over the run. So at a fixed CFL (dt ~ h) every scheme's nu_num is first order in
h; at a fixed h, the cubic ones are first order in dt and the linear one nearly
dt-independent (upwind-like), as the tests measure. Measured / theory (nu = 0.05, T = 1, CFL
0.5): 1.000, 0.998, 0.999 at 16^2, 32^2, 64^2 for sl_linear; 1.041, 1.014, 1.005 for the
cubic schemes (their O(h^3) interpolation part, left out, shrinking).

Compared observable `velocity` (m/s): every face velocity; err_* the RMS over the faces of the
difference from the exact continuous solution. Bound: the amplitude deficit that the theory's
numerical viscosity gives, RMS_0 |A(t) - exp(-2 nu k^2 t)| at worst over the run (A(t) from
dA/dt = -2 k^2 (nu + nu_num(A)) A: the splitting part falls as A^2, the bilinear one about as
A), times a safety factor 1.5 for the mode's distortion and the higher-order terms (the
measured error over the deficit alone: 1.00-1.08 on 16^2 to 64^2, every scheme), plus
round-off. A semi-Lagrangian scheme has no convergence order in dt at a fixed h (the
interpolation error h^2 per step accumulates as h^2 / dt), hence order_meaningful False; its orders are checked on
nu_numerical across grids (tests/cases/test_grid_fluids_taylor_green.py). Variants n16, n64
by name; finer grids by --param n=128.
"""
from __future__ import annotations

import math

import numpy as np

from refsim.case import EPS, Case, Param
from refsim.integrators.semi_lagrangian import parse_scheme
from refsim.models.grid_fluid.mac import MacGrid, stack_faces
from refsim.scene import FluidGrid, Scene

K, U = 1.0, 1.0
SAFETY = 1.5  # the distortion and the O(h + dt) terms: measured err / deficit 1.00-1.08


def _mode_moments(points: int = 256) -> tuple[float, float]:
    """(<q (|u1| + |u2|)>, <q^2>) / <q> over the unit Taylor-Green mode, q = u1^2 + u2^2, by
    midpoint quadrature on points^2 cells (|.| makes it converge as points^-2: ~1e-5)."""
    x = (np.arange(points) + 0.5) * 2 * np.pi / points
    X, Y = np.meshgrid(x, x, indexing="ij")
    u1, u2 = np.sin(X) * np.cos(Y), -np.cos(X) * np.sin(Y)
    q = u1 ** 2 + u2 ** 2
    return float(np.mean(q * (np.abs(u1) + np.abs(u2))) / q.mean()), \
        float(np.mean(q * q) / q.mean())


MOMENTS = _mode_moments()


def interpolation_viscosity(h: float, dt: float, amplitude: float = 1.0) -> float:
    """The bilinear interpolant's numerical viscosity on the Taylor-Green mode of amplitude
    A U: the diffusion nu_a = |u_a| (h - |u_a| dt) / 2 along each axis a (acting on both
    components, u_aa = -u) drains energy at 2 <q (nu_x + nu_y)> A^2; over 2 E and 2 k^2:
    (A U h / 2 <q (|u1| + |u2|)> - (A U)^2 dt / 2 <q^2>) / <q> / (2 k^2)."""
    first, second = MOMENTS
    return (amplitude * U * h / 2 * first - (amplitude * U) ** 2 * dt / 2 * second) / (2 * K ** 2)


def viscous_step_viscosity(nu: float, h: float, dt: float, scheme: str) -> float:
    """The viscous step's exact discrete excess decay rate over 2 nu k^2, over 2 k^2."""
    z = dt * nu * 8 / h ** 2 * math.sin(K * h / 2) ** 2
    rate = (math.log1p(z) if scheme == "implicit" else -math.log1p(-z)) / dt
    return (rate - 2 * nu * K ** 2) / (2 * K ** 2)


def numerical_viscosity(interpolant: str, h: float, dt: float, nu: float = 0.0,
                        scheme: str = "implicit", amplitude: float = 1.0) -> float:
    """Leading-order theory (module doc) at the mode's current amplitude A: A^2 U^2 dt / 8,
    the bilinear part for "linear", and the viscous step's own excess."""
    split = (amplitude * U) ** 2 * dt / 8
    interp = interpolation_viscosity(h, dt, amplitude) if interpolant == "linear" else 0.0
    return split + interp + viscous_step_viscosity(nu, h, dt, scheme)


def amplitude_theory(interpolant: str, h: float, dt: float, nu: float, scheme: str,
                     t_end: float, samples: int = 200):
    """(t, A(t)): dA/dt = -2 k^2 (nu + nu_num(A)) A from A(0) = 1 (the numerical viscosity
    falls with the amplitude: A^2 for the splitting, ~A for the bilinear part), by the
    midpoint rule on `samples` steps (its error ~ (2 nu_eff T / samples)^2, below 1e-6)."""
    t = np.linspace(0.0, t_end, samples + 1)
    a = np.ones(samples + 1)
    rate = lambda amp: -2 * K ** 2 * (nu + numerical_viscosity(  # noqa: E731
        interpolant, h, dt, nu, scheme, amp)) * amp
    step = t_end / samples
    for k in range(samples):  # 200 scalar steps of a 1-unknown ODE: not a hot path
        a[k + 1] = a[k] + step * rate(a[k] + 0.5 * step * rate(a[k]))
    return t, a


class TaylorGreen(Case):
    name = "taylor_green"
    description = ("Taylor-Green vortex on a periodic MAC grid: decay exp(-2 nu k^2 t); each "
                   "semi-Lagrangian scheme's numerical viscosity (excess decay / 2k^2) "
                   "against its theory U^2 dt/8 + interpolation")
    tags = ("grid_fluids", "navier_stokes", "exact", "numerical_viscosity")
    observable, units = "velocity", "m/s"
    params = {
        "n": Param(32, 8, 1024, "cells a side on [0, 2 pi]"),
        "nu": Param(0.05, 0.0, 10.0, "kinematic viscosity (m^2/s)"),
        "cfl": Param(0.5, 0.0, 4.0, "dt = cfl h / U", low_inclusive=False),
        "t_end": Param(1.0, 0.0, 100.0, "duration (s)", low_inclusive=False),
        "viscosity_scheme": Param("implicit", choices=("implicit", "explicit")),
    }
    # finer grids with --param n=128 (every registered variant runs in the case contract
    # tests with every solver: 128^2 took 13-130 s a run there)
    variants = {"default": {}, "n16": {"n": 16}, "n64": {"n": 64},
                "inviscid": {"nu": 0.0}, "solvers": {"n": 16, "t_end": 0.5}}
    default_variants = quick_variants = ("default",)
    alternatives_variants = ("solvers",)  # cg and pyamg beside direct: a short, small run
    # no order in dt at a fixed h: the interpolation's error accumulates as h^(p+1) / dt
    # (module doc); the orders are checked on nu_numerical across grids instead
    order_meaningful = False

    # -- grid and scene -----------------------------------------------------------------------
    @staticmethod
    def grid(p) -> MacGrid:
        n = int(p["n"])
        if n != p["n"]:
            raise ValueError(f"taylor_green.n must be an integer, got {p['n']}")
        return MacGrid(n, n, 2 * np.pi / n, (True, True))

    def mode(self, p, amplitude=1.0):
        """(u, v) of the Taylor-Green mode times `amplitude` on the MAC faces."""
        grid = self.grid(p)
        pu, pv = grid.u_points(), grid.v_points()
        u = U * np.sin(K * pu[..., 0]) * np.cos(K * pu[..., 1])
        v = -U * np.cos(K * pv[..., 0]) * np.sin(K * pv[..., 1])
        u[-1], v[:, -1] = u[0], v[:, 0]
        return amplitude * u, amplitude * v

    def scene(self, p):
        grid, (u, v) = self.grid(p), self.mode(p)
        part = FluidGrid(grid.nx, grid.ny, grid.h, u, v, sides="periodic", nu=p["nu"],
                         viscosity_scheme=p["viscosity_scheme"])
        return Scene(parts=(part,), dim=2)

    def t_end(self, p):
        return float(p["t_end"])

    def reference_dt(self, p):
        steps = max(1, round(p["t_end"] / (p["cfl"] * self.grid(p).h / U)))
        return p["t_end"] / steps

    def dts(self, p):
        return [self.reference_dt(p)]

    def bodies(self, p):
        return int(p["n"]) ** 2

    # -- observables and reference ------------------------------------------------------------
    _faces = staticmethod(stack_faces)

    def observables(self, p, obs):
        return {"velocity": self._faces(obs["grid.u"], obs["grid.v"]),
                "divergence": np.asarray(obs["divergence"], float)}

    def decay(self, p, t):
        return np.exp(-2 * p["nu"] * K ** 2 * np.asarray(t, float))

    def reference(self, p, t):
        u, v = self.mode(p)
        return {"velocity": self.decay(p, t)[:, None] * self._faces(u[None], v[None])}

    def error(self, p, observed, reference):
        """RMS over the faces of the velocity difference, per sample."""
        diff = np.asarray(observed["velocity"]) - np.asarray(reference["velocity"])
        return np.sqrt(np.mean(diff ** 2, axis=1))

    def motion_scale(self, p):
        """RMS of the initial face velocities (1/2 for the unit mode)."""
        return float(np.sqrt(np.mean(self._faces(*[a[None] for a in self.mode(p)]) ** 2)))

    def target_error(self, p):
        return 1e-2 * self.motion_scale(p)

    def energy(self, p, obs):
        """Kinetic energy per unit density, (h^2 / 2) sum of the squared distinct faces."""
        vel = np.asarray(obs["velocity"] if "velocity" in obs else
                         self._faces(obs["grid.u"], obs["grid.v"]))
        n, h = int(p["n"]), self.grid(p).h
        u = vel[:, :(n + 1) * n].reshape(-1, n + 1, n)[:, :-1]
        v = vel[:, (n + 1) * n:].reshape(-1, n, n + 1)[:, :, :-1]
        return 0.5 * h ** 2 * (np.sum(u ** 2, axis=(1, 2)) + np.sum(v ** 2, axis=(1, 2)))

    def energy_scale(self, p):
        return float(self.energy(p, {"velocity": self._faces(*[a[None] for a in
                                                               self.mode(p)])})[0])

    def reference_energy(self, p, t):
        return self.energy_scale(p) * self.decay(p, t) ** 2

    def extra_metrics(self, p, obs, observed, reference):
        t = np.asarray(obs["t"], float)
        energy = self.energy(p, observed)
        rate = -math.log(energy[-1] / energy[0]) / (2 * t[-1])
        return {"nu_numerical": float((rate - 2 * p["nu"] * K ** 2) / (2 * K ** 2)),
                "divergence": float(np.max(observed["divergence"]))}

    # -- tolerance ----------------------------------------------------------------------------
    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        interpolant, _ = parse_scheme(integrator)
        grid, T = self.grid(p), p["t_end"]
        t, amp = amplitude_theory(interpolant, grid.h, dt, p["nu"], p["viscosity_scheme"], T)
        nu_num = self.predicted_viscosity(p, interpolant, dt)
        scale = self.motion_scale(p)
        excess = amp - np.exp(-2 * p["nu"] * K ** 2 * t)
        amplitude = SAFETY * scale * float(np.max(np.abs(excess)))
        roundoff = 64 * round(T / dt) * EPS * scale
        return amplitude + roundoff, (
            f"the amplitude deficit of the theory's numerical viscosity A^2 U^2 dt/8"
            f"{' + bilinear(A) ' if interpolant == 'linear' else ''} + the viscous step's "
            f"(mean over the run {nu_num:.3g} m^2/s): RMS_0 max_t |A(t) - exp(-2 nu t)| x "
            f"{SAFETY:g} (distortion, O(h + dt) terms) = {amplitude:.3g}; plus round-off "
            f"64 n eps RMS_0 = {roundoff:.3g}")

    def predicted_viscosity(self, p, interpolant: str, dt: float) -> float:
        """The theory's nu_numerical as this case measures it: -ln(A(T)) / (2 k^2 T) - nu."""
        t, amp = amplitude_theory(interpolant, self.grid(p).h, dt, p["nu"],
                                  p["viscosity_scheme"], p["t_end"])
        return float(-math.log(amp[-1]) / (2 * K ** 2 * t[-1]) - p["nu"])


CASE = TaylorGreen()
