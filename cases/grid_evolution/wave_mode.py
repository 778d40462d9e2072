"""The wave equation u_tt = c^2 lap u on the unit square (slides 000/001; no scheme is printed
there), a standing Fourier mode phi released from rest on a grid of `cells` intervals a side
(Dirichlet sides by default; `_modes.ModeGrid`).

Exact discrete solutions separate the errors:
- space: the semi-discrete system keeps the mode and oscillates it as cos(omega_h t),
  omega_h = c sqrt(-mu_h) = c (2 / h) sqrt(d) sin(theta / 2) (theta = k pi h), the continuum as
  cos(omega t), omega = c k pi sqrt(d) (`err_continuum` at the last sample);
- time: each stepper maps the mode's (u, v) by a 2x2 matrix M(y), y = omega_h dt, in closed
  form (`step_matrix`); u_n = [M^n]_00 phi exactly. The three-level leapfrog (stormer_verlet,
  and velocity Verlet, which gives the same u from rest) has u_n = cos(n w~ dt) phi with the
  discrete dispersion relation sin(w~ dt / 2) = C sqrt(d) sin(theta / 2), C = c dt / h: at
  C = 1 in 1D, w~ = omega and the scheme is exact (space and time errors cancel: `err_continuum`
  is round-off at the default sweep's first dt). The compared error (`u`, max over points) is
  against the semi-discrete solution; the tolerance is the exact discrete deviation plus
  round-off.
- stability: leapfrog needs omega_max dt <= 2, omega_max = 2 c sqrt(d) / h: C <= 1 / sqrt(d)
  (1D 1, 2D 1/sqrt 2); RK4 C <= sqrt(2 / d); the sparse implicit steppers are unconditionally
  stable. `refsim stress --case wave_mode [--variant 2d]` measures them on noise.
Energy: 1/2 sum (v^2 + c^2 |grad_h u|^2) h^d with forward differences (= -u . L_h u by
summation by parts): exactly conserved by the semi-discrete system.
"""
from __future__ import annotations

import math

import numpy as np

from refsim.case import EPS, Param
from refsim.scene import Grid
from refsim.stress.search import theory as oscillator_limit

from ._modes import BOUNDARIES, ModeFieldCase, ModeGrid

COURANTS = (1.0, 0.5, 0.25)  # C = c dt / h of the timed sweep
ORDER_COURANTS = (0.125, 0.0625)


def step_matrix(integrator: str, omega: float, h: float) -> np.ndarray:
    """M with (u, v)_{n+1} = M (u, v)_n for u'' = -omega^2 u, in closed form per stepper."""
    y2, a = (omega * h) ** 2, np.array([[0.0, 1.0], [-omega ** 2, 0.0]])
    eye = np.eye(2)
    if integrator == "symplectic_euler":  # kick then drift
        return np.array([[1.0 - y2, h], [-omega ** 2 * h, 1.0]])
    if integrator in ("velocity_verlet", "stormer_verlet", "leapfrog"):
        return np.array([[1.0 - y2 / 2, h], [-omega ** 2 * h * (1.0 - y2 / 4), 1.0 - y2 / 2]])
    if integrator == "rk4":
        ha = h * a
        return eye + ha + ha @ ha / 2 + ha @ ha @ ha / 6 + ha @ ha @ ha @ ha / 24
    if integrator == "implicit_euler":
        return np.linalg.inv(eye - h * a)
    if integrator == "implicit_midpoint":
        return np.linalg.solve(eye - h * a / 2, eye + h * a / 2)
    raise ValueError(f"wave_mode has no closed-form step for {integrator!r}")


def discrete_u(integrator: str, omega: float, h: float, steps) -> np.ndarray:
    """[M^n]_00 for each n in steps (u from rest, amplitude 1): by the eigenvalues of M,
    lambda^n, so every n costs the same."""
    m = step_matrix(integrator, omega, h)
    values, vectors = np.linalg.eig(m)
    coeffs = np.linalg.solve(vectors, np.array([1.0, 0.0]))
    powers = np.power(values[None, :], np.asarray(steps)[:, None])
    return np.real(powers @ (vectors[0] * coeffs))


class WaveMode(ModeFieldCase):
    name = "wave_mode"
    description = ("wave equation on a grid, a standing mode from rest: discrete dispersion "
                   "relation of each scheme, leapfrog exact at C = 1 in 1D, C <= 1/sqrt(d)")
    tags = ("fdm", "grid", "wave", "exact")
    params = {
        "dim": Param(1, 1, 3, "spatial dimensions"),
        "cells": Param(32, 4, 4096, "intervals per axis (unit length)"),
        "k": Param(1, 1, 2048, "wavenumber on every axis"),
        "wave_speed": Param(1.0, 0.0, 1e6, "c (m/s)", low_inclusive=False),
        "boundary": Param("dirichlet", choices=BOUNDARIES),
        "periods": Param(1.0, 0.0, 1e4, "t_end in periods 2 pi / omega", low_inclusive=False),
        "initial": Param("mode", choices=("mode", "noise")),
        "seed": Param(15, 0, 2 ** 31, "noise seed"),
    }
    variants = {"1d": {}, "2d": {"dim": 2}, "3d": {"dim": 3, "cells": 16},
                "long_1d": {"periods": 100.0}}
    default_variants = quick_variants = ("1d",)

    def scene(self, p):
        g = self.grid(p)
        u0 = g.noise(p["seed"]) if p["initial"] == "noise" else g.mode()
        return g.scene("wave", {"u": u0, "v": np.zeros_like(u0)},
                       {"wave_speed": p["wave_speed"]})

    def omega_h(self, p) -> float:
        return p["wave_speed"] * math.sqrt(-self.grid(p).discrete_eigenvalue())

    def t_end(self, p):
        omega = p["wave_speed"] * math.sqrt(-self.grid(p).continuum_eigenvalue())
        return p["periods"] * 2.0 * math.pi / omega

    def dt_of(self, p, courant):
        return courant * self.grid(p).h / p["wave_speed"]

    def dts(self, p):
        return [self.dt_of(p, c) for c in COURANTS]

    def order_dts(self, p):
        return [self.dt_of(p, c) for c in ORDER_COURANTS]

    def reference_dt(self, p):
        return self.dt_of(p, 0.25)

    def reference(self, p, t):
        return {"u": np.multiply.outer(np.cos(self.omega_h(p) * np.asarray(t, float)),
                                       self.grid(p).mode())}

    def energy(self, p, obs):
        g = self.grid(p)
        u, v = np.asarray(obs["grid.u"], float), np.asarray(obs["grid.v"], float)
        grad2 = 0.0
        for axis in range(1, u.ndim):
            wrapped = np.concatenate([u, np.take(u, [0], axis=axis)], axis=axis) \
                if g.boundary == "periodic" else u
            slope = np.diff(wrapped, axis=axis) / g.h
            grad2 = grad2 + np.sum(slope.reshape(len(u), -1) ** 2, axis=1)
        kinetic = np.sum(v.reshape(len(v), -1) ** 2, axis=1)
        return 0.5 * g.h ** g.dim * (kinetic + p["wave_speed"] ** 2 * grad2)

    def energy_period(self, p, settings=None):
        """The semi-discrete wave equation conserves its energy (separable: v^2/2 plus the
        gradient term): the mode's period 2 pi / omega_h (judged where a quarter of the run
        spans it: `long_1d`)."""
        return 2.0 * math.pi / self.omega_h(p)

    def energy_scale(self, p):
        u0 = self.scene(p).part(Grid).fields["u"]
        return float(self.energy(p, {"grid.u": u0[None], "grid.v": np.zeros_like(u0)[None],
                                     "t": np.zeros(1)})[0])

    def extra_metrics(self, p, obs, observed, reference):
        """err_continuum: max |u - cos(omega t) phi| at the last sample (space and time error
        against the PDE)."""
        g, t = self.grid(p), float(np.asarray(obs["t"], float)[-1])
        omega = p["wave_speed"] * math.sqrt(-g.continuum_eigenvalue())
        u = np.asarray(obs["grid.u"], float)[-1]
        return {"err_continuum": float(np.max(np.abs(u - math.cos(omega * t) * g.mode())))}

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        steps = round(self.t_end(p) / dt)
        n = np.arange(steps + 1)
        omega = self.omega_h(p)
        gap = discrete_u(integrator, omega, dt, n) - np.cos(omega * dt * n)
        deviation = float(np.max(np.abs(gap)))
        courant = p["wave_speed"] * dt / self.grid(p).h
        bound = 4.0 * steps * (1.0 + 4.0 * self.grid(p).dim * courant ** 2) * EPS
        return deviation + bound, (
            f"the exact discrete solution [M(y)^n]_00 phi of {integrator} (M its closed-form "
            f"step on the mode, y = omega_h dt) deviates from cos(omega_h t) phi by at most "
            f"{deviation:.6g} over the run; plus round-off 4 n (1 + 4 d C^2) eps = {bound:.3g} "
            f"(n = {steps} steps, each rounding u and v by at most (1 + 4 d C^2) eps of the "
            "amplitude (the stencil's 2d + 1 terms scaled by C^2); a neutrally stable step "
            "keeps them undamped: Henrici's linear worst case; factor 4: u, v, the stages and "
            "the reference)")

    def stability(self, p):
        """`refsim stress`: the Courant number y = C = c dt / h on noise over an even periodic
        grid (the sawtooth has omega_max = 2 c sqrt(d) / h); theory: the stepper's limit on
        a linear oscillator (omega dt <= 2 leapfrog, 2 sqrt 2 RK4, unbounded implicit) over
        2 sqrt(d)."""
        from refsim.stress.spec import StabilitySpec
        q = {**p, "initial": "noise", "boundary": "periodic"}
        dim, periods = int(p["dim"]), 200

        def theory(stepper, settings):
            if stepper is None:
                return math.nan, "no refsim stepper equals this integrator"
            limit = oscillator_limit(stepper)
            return limit / (2 * math.sqrt(dim)), (
                f"C <= y_max / (2 sqrt d), y_max = {limit:.6g} the linear-oscillator limit of "
                f"{stepper.family}; sawtooth omega_max = 2 c sqrt(d) / h")
        return StabilitySpec(
            name="Courant number C = c dt / h", dt_unit=ModeGrid(q).h / p["wave_speed"],
            theory=theory, source="von Neumann on the sawtooth mode",
            energy_bound=1e4 * self.energy_scale(q),
            params={"initial": "noise", "boundary": "periodic"}, periods=periods,
            quick_periods=20, cycle=2 * math.pi / (2 * math.sqrt(dim)),
            resolution=self.resolution(q, periods),
            resolution_reason=(
                "past the limit the sawtooth (a share >= 1/(100 N) of the noise's energy) must "
                "grow by F = 1e4 within the judged steps: the smallest C above the limit where "
                "rho(M)^(2 n) reaches 100 N F, largest over leapfrog and RK4"))

    def resolution(self, q, periods) -> float:
        g, gaps = ModeGrid(q), []
        need = math.log(100.0 * np.prod(g.shape) * 1e4)
        cycle = 2 * math.pi / (2 * math.sqrt(g.dim))
        for name, y_max in (("velocity_verlet", 2.0), ("rk4", 2.0 * math.sqrt(2.0))):
            c0 = y_max / (2 * math.sqrt(g.dim))
            for c in c0 * (1 + np.geomspace(1e-7, 0.5, 2000)):
                steps = min(math.ceil(periods * cycle / c), 10 * cycle / (2 * math.pi) * periods)
                omega = 2 * math.sqrt(g.dim) / g.h  # c = 1 in units of dt_unit
                rho = max(abs(np.linalg.eigvals(step_matrix(name, omega, c * g.h))))
                if 2 * steps * math.log(rho) >= need:
                    gaps.append(c - c0)
                    break
        return max(gaps)


CASE = WaveMode()
