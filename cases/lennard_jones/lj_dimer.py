"""Lennard-Jones dimer: two atoms of mass m, released from rest at the separation r0 + A, where
r0 = 2^(1/6) sigma is the minimum of U(r) = 4 eps ((sigma/r)^12 - (sigma/r)^6). No cut-off.

Small vibrations (docs/models.md#fields-lennard-jones-dimer):
k = U''(r0) = 4 eps (156 sigma^12/r0^14 - 42 sigma^6/r0^8)
= (72 eps / r0^2) (156/4 - 42/2) / 18 = 72 eps / r0^2 = 36 2^(2/3) eps / sigma^2 = 57.146
eps/sigma^2 (at r0: (sigma/r0)^6 = 1/2); the relative coordinate r moves with the reduced mass
mu = m/2, so w0 = sqrt(k / mu) = sqrt(2 k / m).
Exact period at amplitude A (energy conservation, mu r'^2 / 2 + U(r) = E = U(r0 + A)):
    T(A) = 2 int_{r_min}^{r_max} dr / sqrt(2 (E - U(r)) / mu),  r_max = r0 + A, U(r_min) = E,
evaluated with scipy.integrate.quad after r = c - h cos(theta) (c, h the midpoint and half
width of [r_min, r_max]), which removes the inverse square-root endpoint singularities
(dr = h sin(theta) dtheta and E - U ~ theta^2 at both ends); E - U is factored through
r - r_end, so it is free of cancellation near the turning points (`exact_period`).
T(A) -> 2 pi / w0 as A -> 0; the anharmonic shift grows like A^2 (`period_shift`).
Reference trajectory: r(t) from a converged run, scipy's DOP853 on mu r'' = -U'(r) with
rtol 1e-13 (its error, < 1e-11 sigma over these horizons, checked in the tests against the
quadrature period), not an inversion of t(r).
Defaults eps = 1.5 J, m = 2 kg (not 1: an engine dropping the mass or the well depth fails).
Tolerance: twice the exact discrete error of the named method on the harmonic dimer at w0
(refsim.expected), the factor 2 for the anharmonic part (see `tolerance`).
Compared observable `r` (m), the separation. Extra metrics: `period_error`, the relative error
of the oscillation period measured on the run (upward crossings of the midpoint c located by
cubic Hermite interpolation of (r, r')) against the exact T(A); `momentum_drift`, |sum m v|
(kg m/s), zero to round-off for a symmetric pair force.
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq

from refsim.case import ADAPTIVE_REASON, Case, Param, adaptive_rtol, roundoff_tolerance
from refsim.expected import discrete_solution
from refsim.scene import Particles, Scene
from refsim.scene.lennard_jones import LennardJones

R0_OVER_SIGMA = 2.0 ** (1.0 / 6.0)
K_REDUCED = 36.0 * 2.0 ** (2.0 / 3.0)  # U''(r0) sigma^2 / eps = 57.146...
SAFETY = 2.0  # the one safety factor of the tolerance (the anharmonic part, see tolerance)
REFERENCE_ERROR = 1e-11  # sigma: DOP853 at rtol 1e-13 over these horizons (module docstring)


def potential(r, eps, sigma):
    s6 = (sigma / np.asarray(r, float)) ** 6
    return 4.0 * eps * (s6 * s6 - s6)


def force(r, eps, sigma):
    """-U'(r) = 24 eps (2 (sigma/r)^12 - (sigma/r)^6) / r."""
    s6 = (sigma / np.asarray(r, float)) ** 6
    return 24.0 * eps * (2.0 * s6 * s6 - s6) / r


def curvature(r, eps, sigma):
    """U''(r) = 4 eps (156 (sigma/r)^12 - 42 (sigma/r)^6) / r^2."""
    s6 = (sigma / np.asarray(r, float)) ** 6
    return 4.0 * eps * (156.0 * s6 * s6 - 42.0 * s6) / (r * r)


def small_vibration_omega(eps, sigma, mass):
    """w0 = sqrt(2 k / m), k = 36 2^(2/3) eps / sigma^2."""
    return math.sqrt(2.0 * K_REDUCED * eps / (sigma * sigma) / mass)


def turning_points(amplitude, eps, sigma):
    """(r_min, r_max): r_max = r0 + A, r_min < r0 the other root of U(r) = U(r_max)."""
    r0 = R0_OVER_SIGMA * sigma
    r_max = r0 + amplitude
    energy = float(potential(r_max, eps, sigma))
    r_min = brentq(lambda r: float(potential(r, eps, sigma)) - energy, 0.5 * sigma, r0,
                   xtol=1e-15 * sigma, rtol=4 * np.finfo(float).eps)
    return r_min, r_max


def _gap_rate(r, r_end, eps, sigma):
    """(U(r_end) - U(r)) / (r - r_end) without cancellation: with s^6 = (sigma/r)^6,
    U(r_end) - U(r) = 4 eps (s_end^6 - s^6)(s_end^6 + s^6 - 1) and s_end^6 - s^6 =
    sigma^6 (r - r_end) (r^5 + r^4 r_end + ... + r_end^5) / (r r_end)^6."""
    powers = sum(r ** k * r_end ** (5 - k) for k in range(6))
    s6, s6_end = (sigma / r) ** 6, (sigma / r_end) ** 6
    return 4.0 * eps * sigma ** 6 * powers / (r * r_end) ** 6 * (s6_end + s6 - 1.0)


def exact_period(amplitude, eps, sigma, mass):
    """T(A) = 2 int dr / sqrt(2 (E - U) / mu) by quadrature (see the module docstring). With
    r = c - h cos(theta), r - r_min = 2 h sin^2(theta/2) and r - r_max = -2 h cos^2(theta/2),
    so E - U = (r - r_end) x `_gap_rate` and the integrand h sin(theta) / sqrt(2 (E - U) / mu)
    is cos(theta/2) sqrt(h mu / rate_min) on [0, pi/2] (E = U(r_min)) and sin(theta/2)
    sqrt(h mu / -rate_max) on [pi/2, pi] (E = U(r_max)): smooth, no endpoint singularity."""
    mu = 0.5 * mass
    r_min, r_max = turning_points(amplitude, eps, sigma)
    centre, half = 0.5 * (r_max + r_min), 0.5 * (r_max - r_min)

    def inner(theta):
        rate = _gap_rate(centre - half * math.cos(theta), r_min, eps, sigma)
        return math.cos(0.5 * theta) * math.sqrt(half * mu / rate)

    def outer(theta):
        rate = _gap_rate(centre - half * math.cos(theta), r_max, eps, sigma)
        return math.sin(0.5 * theta) * math.sqrt(half * mu / -rate)
    first, _ = quad(inner, 0.0, 0.5 * math.pi, epsabs=0.0, epsrel=1e-13, limit=200)
    second, _ = quad(outer, 0.5 * math.pi, math.pi, epsabs=0.0, epsrel=1e-13, limit=200)
    return 2.0 * (first + second)


@lru_cache(maxsize=16)
def _reference_solution(amplitude, eps, sigma, mass, t_end):
    mu = 0.5 * mass

    def rhs(t, y):
        return (y[1], float(force(y[0], eps, sigma)) / mu)
    y0 = (R0_OVER_SIGMA * sigma + amplitude, 0.0)
    return solve_ivp(rhs, (0.0, t_end), y0, method="DOP853", rtol=1e-13,
                     atol=1e-16 * sigma, dense_output=True)


def reference_separation(p, t):
    """(r, r') at times t from the converged DOP853 run (see the docstring)."""
    sol = _reference_solution(p["amplitude"], p["epsilon"], p["sigma"], p["mass"],
                              float(LJDimer().t_end(p)))
    r, rdot = sol.sol(np.asarray(t, float))
    return r, rdot


def crossing_times(t, r, rdot, level):
    """Times of the upward crossings of `level` by r(t), located inside each sample interval
    by the cubic Hermite interpolant of (r, r') (a few vectorised Newton steps)."""
    t, r, rdot = (np.asarray(a, float) for a in (t, r, rdot))
    up = np.flatnonzero((r[:-1] < level) & (r[1:] >= level))
    h = t[up + 1] - t[up]
    y0, y1, d0, d1 = r[up] - level, r[up + 1] - level, rdot[up] * h, rdot[up + 1] * h
    s = y0 / (y0 - y1)  # linear guess in [0, 1]
    for _ in range(8):
        h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
        h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
        value = h00 * y0 + h10 * d0 + h01 * y1 + h11 * d1
        slope = ((6 * s**2 - 6 * s) * (y0 - y1) + (3 * s**2 - 4 * s + 1) * d0
                 + (3 * s**2 - 2 * s) * d1)
        s = np.clip(s - value / np.where(slope == 0, 1.0, slope), 0.0, 1.0)
    return t[up] + s * h


class LJDimer(Case):
    name = "lj_dimer"
    description = ("Lennard-Jones dimer released at r0 + A: separation vs a converged run, "
                   "period vs the exact quadrature T(A), w0 = sqrt(2 k / m)")
    tags = ("particle_fields", "lennard_jones", "oscillation", "exact")
    observable, units = "r", "m"
    params = {
        "amplitude": Param(0.01, 0.0, 0.5, "initial stretch A = r(0) - r0 (m)",
                           low_inclusive=False),
        "epsilon": Param(1.5, 0.0, 1e3, "well depth (J)", low_inclusive=False),
        "sigma": Param(1.0, 0.0, 1e3, "LJ length (m)", low_inclusive=False),
        "mass": Param(2.0, 0.0, 1e6, "mass of each atom (kg)", low_inclusive=False),
        "periods": Param(2.0, 0.0, 1e4, "duration in small-vibration periods 2 pi / w0",
                         low_inclusive=False),
    }
    variants = {"small": {}, "large": {"amplitude": 0.1}, "long": {"periods": 100.0}}
    quick_variants = ("small",)
    default_variants = ("small",)

    def omega0(self, p):
        return small_vibration_omega(p["epsilon"], p["sigma"], p["mass"])

    def omega_max(self, p):
        """The fastest local frequency on the orbit, sqrt(U''(r_min) / mu): U'' is largest at
        the inner turning point."""
        r_min, _ = turning_points(p["amplitude"], p["epsilon"], p["sigma"])
        return math.sqrt(float(curvature(r_min, p["epsilon"], p["sigma"])) / (0.5 * p["mass"]))

    def scene(self, p):
        r_start = R0_OVER_SIGMA * p["sigma"] + p["amplitude"]
        x = np.array([[-0.5 * r_start, 0.0, 0.0], [0.5 * r_start, 0.0, 0.0]])
        atoms = Particles(mass=np.full(2, p["mass"]), position=x)
        return Scene(parts=(atoms, LennardJones(p["epsilon"], p["sigma"])))

    def t_end(self, p):
        return p["periods"] * 2.0 * math.pi / self.omega0(p)

    def dts(self, p):
        period = 2.0 * math.pi / self.omega0(p)
        return [period / 20, period / 40, period / 80]  # w0 dt = 0.31 .. 0.079

    def order_dts(self, p):
        """Finer accuracy-only steps, so that the order fit spans a decade of dt above the
        error floor (RK4 at A = 0.01 sigma stays 1e3 above it at T/160)."""
        period = 2.0 * math.pi / self.omega0(p)
        return [period / 160, period / 200]  # T/20 .. T/200: a decade

    def reference_dt(self, p):
        return self.dts(p)[-1]

    def bodies(self, p):
        return 2

    def motion_scale(self, p):
        return p["amplitude"]

    def error_floor(self, p):
        return self._roundoff(p, self.reference_dt(p))[0] + 1e-11 * p["sigma"]

    def observables(self, p, obs):
        x, v = np.asarray(obs["x"], float), np.asarray(obs["v"], float)
        d, dv = x[:, 1] - x[:, 0], v[:, 1] - v[:, 0]
        r = np.linalg.norm(d, axis=1)
        return {"r": r, "r_dot": np.einsum("ij,ij->i", d, dv) / r}

    def reference(self, p, t):
        r, rdot = reference_separation(p, t)
        return {"r": r, "r_dot": rdot}

    def energy(self, p, obs):
        v = np.asarray(obs["v"], float)
        r = self.observables(p, obs)["r"]
        kinetic = 0.5 * p["mass"] * np.sum(v * v, axis=(1, 2))
        return kinetic + potential(r, p["epsilon"], p["sigma"])

    def energy_period(self, p, settings=None):
        """Two atoms in open space: H = |p|^2 / (2 m) + U(r) is separable and conserved; the
        radial oscillation's period (quadrature). Judged where a quarter of the run spans it
        (the `long` variant)."""
        return exact_period(p["amplitude"], p["epsilon"], p["sigma"], p["mass"])

    def energy_scale(self, p):
        """The oscillation energy 1/2 k A^2."""
        return 0.5 * K_REDUCED * p["epsilon"] / p["sigma"] ** 2 * p["amplitude"] ** 2

    def extra_metrics(self, p, obs, observed, reference):
        r_min, r_max = turning_points(p["amplitude"], p["epsilon"], p["sigma"])
        times = crossing_times(obs["t"], observed["r"], observed["r_dot"], 0.5 * (r_min + r_max))
        exact = exact_period(p["amplitude"], p["epsilon"], p["sigma"], p["mass"])
        measured = (times[-1] - times[0]) / (len(times) - 1) if len(times) > 1 else np.nan
        momentum = p["mass"] * np.sum(np.asarray(obs["v"], float), axis=1)
        return {"period_error": float(abs(measured / exact - 1.0)),
                "period_shift": float(exact * self.omega0(p) / (2 * math.pi) - 1.0),
                "momentum_drift": float(np.max(np.linalg.norm(momentum, axis=1)))}

    def period_sensitivity(self, p):
        """kappa = dlnT/dlnE about the orbit's oscillation energy E - U(r0) (central
        difference of the quadrature period in A, dE/dA from U'(r_max))."""
        a, eps, sigma, mass = p["amplitude"], p["epsilon"], p["sigma"], p["mass"]
        da = 1e-3 * a
        dlnT = math.log(exact_period(a + da, eps, sigma, mass)
                        / exact_period(a - da, eps, sigma, mass)) / (2 * da)
        e_osc = float(potential(R0_OVER_SIGMA * sigma + a, eps, sigma)) + eps
        return abs(dlnT * e_osc / float(-force(R0_OVER_SIGMA * sigma + a, eps, sigma)))

    def _roundoff(self, p, dt):
        """S = r(0) + A: rounding the two positions (each to eps/2 of r0/2) and the velocities
        (relative speed <= w A) moves r by at most eps (r0 + A)."""
        steps = int(round(self.t_end(p) / dt))
        return roundoff_tolerance(steps, R0_OVER_SIGMA * p["sigma"] + p["amplitude"])

    def sampled_steps(self, p, dt) -> np.ndarray:
        """The step counts the job observes at (stride as refsim/run/job.py computes it)."""
        steps = int(round(self.t_end(p) / dt))
        stride = max(1, int(round(self.sample_dt(p) / dt)))
        return np.unique(np.append(np.arange(0, steps + 1, stride), steps))

    def harmonic_error(self, p, integrator, dt) -> float:
        """max over the samples of |r_k - r(t_k)| of the named method's exact discrete
        solution on the harmonic dimer mu r'' = -k (r - r0) (refsim.expected; every method here
        acts on the relative coordinate as on the reduced one-body problem, a linear change of
        variables), from r0 + A at rest, against A cos(w0 t)."""
        w, steps = self.omega0(p), self.sampled_steps(p, dt)
        x, _ = discrete_solution(integrator, -w * w, None, p["amplitude"], 0.0, dt, steps)
        return float(np.max(np.abs(x[:, 0] - p["amplitude"] * np.cos(w * steps * dt))))

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        roundoff, roundoff_reason = self._roundoff(p, dt)
        floor = f"; plus the reference's own error {REFERENCE_ERROR:g} sigma"
        reference = REFERENCE_ERROR * p["sigma"]
        rtol = adaptive_rtol(integrator)
        if rtol is not None:
            w_t = self.omega_max(p) * self.t_end(p)
            return 10 * rtol * p["amplitude"] * w_t + roundoff + reference, \
                ADAPTIVE_REASON + floor + roundoff_reason
        harmonic = self.harmonic_error(p, integrator, dt)
        ratio = self.omega_max(p) / self.omega0(p)
        return SAFETY * harmonic + roundoff + reference, (
            f"{SAFETY:g} x {harmonic:.4g} m: the exact discrete solution of {integrator} on the "
            f"harmonic dimer (w0 = {self.omega0(p):.4g} rad/s, refsim.expected) against "
            f"A cos(w0 t), max over the samples; safety factor {SAFETY:g} for the anharmonic "
            f"potential (the local frequency reaches {ratio:.3f} w0 at r_min; measured: the "
            "real error is 0.97..1.2 of the harmonic one at A = 0.01 sigma, 0.74..1.72 at "
            "0.1 sigma)" + floor + roundoff_reason)


CASE = LJDimer()
