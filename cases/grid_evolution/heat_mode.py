"""The heat equation u_t = D lap u on the unit square (slides 000/001: FTCS with its stability
bound dt/dx^2 <= 1/2), started from one Fourier mode phi of wavenumber k, on a grid of `cells`
intervals a side (1D, 2D or 3D; Dirichlet, Neumann or periodic sides: `_modes.ModeGrid`).

Exact discrete solutions separate the errors:
- space: the semi-discrete system u' = D L_h u keeps the mode and decays it as exp(D mu_h t),
  mu_h = -d (4 / h^2) sin^2(theta / 2) (theta = k pi h); the continuum as exp(D mu t), mu =
  -d (k pi)^2. Their gap is the O(h^2) space error (`err_continuum`);
- time: a stepper of stability function R multiplies the mode by exactly G = R(h D mu_h) a
  step: FTCS G = 1 - 4 d r sin^2(theta / 2) (r = D dt / h^2), implicit Euler 1 / (1 - z),
  Crank-Nicolson (1 + z/2) / (1 - z/2), RK tableaux their polynomial. The compared error
  (`u`, max over grid points) is against the semi-discrete solution, so it is the stepper's
  alone: |G^n - exp(n z)| max|phi|; the tolerance is that plus round-off, and `oracle_err`
  = max |u_n - G^n phi| must be round-off (tests).
- stability: FTCS is stable iff r <= 1 / (2 d) (1D 1/2, 2D 1/4, 3D 1/6): the slide's 1D bound
  does not hold in 2D, and the 2D default sweep's first dt, r = 1/2, diverges for every
  explicit stepper (RK4's real interval 2.785 gives r <= 0.696 / d). `refsim stress --case
  heat_mode [--variant 1d|3d]` measures the limits on noise (every mode present).
Energy: E = 1/2 sum w u^2 (trapezoid weights), the grid's own energy: it decays under every
stable step, so a growing one means an unbounded run (never a decaying one divided by its
decay). Its reference is the semi-discrete mode's E0 exp(2 D mu_h t), so energy_drift is the
stepper's energy error in units of E0 (noise: no reference, E0 kept).
"""
from __future__ import annotations

import math

import numpy as np

from refsim.case import EPS, Param
from refsim.scene import Grid

from ._modes import (
    BOUNDARIES,
    ModeFieldCase,
    ModeGrid,
    heat_stepper,
    real_stability_limit,
    stages,
)

DIFFUSION_RS = (0.5, 0.25, 0.125)  # r = D dt / h^2 of the timed sweep
ORDER_RS = (1.0 / 16, 1.0 / 32, 1.0 / 64)  # accuracy only: the stable explicit rows span 16x


class HeatMode(ModeFieldCase):
    name = "heat_mode"
    description = ("heat equation on a grid from one Fourier mode: exact amplification factor "
                   "of each scheme per step, stability limit r <= 1/(2d)")
    tags = ("fdm", "grid", "diffusion", "exact")
    params = {
        "dim": Param(2, 1, 3, "spatial dimensions"),
        "cells": Param(32, 4, 4096, "intervals per axis (unit length)"),
        "k": Param(1, 1, 2048, "wavenumber on every axis"),
        "diffusivity": Param(1.0, 0.0, 1e6, "D (m^2/s)", low_inclusive=False),
        "boundary": Param("dirichlet", choices=BOUNDARIES),
        "decay_times": Param(1.0, 0.0, 1e3, "t_end in units of 1 / (D |mu|)",
                             low_inclusive=False),
        "initial": Param("mode", choices=("mode", "noise")),
        "seed": Param(15, 0, 2 ** 31, "noise seed"),
    }
    variants = {"2d": {}, "1d": {"dim": 1}, "3d": {"dim": 3, "cells": 16},
                "neumann": {"boundary": "neumann"}, "periodic": {"boundary": "periodic"},
                "fine_1d": {"dim": 1, "cells": 256}}
    default_variants = quick_variants = ("2d",)

    def scene(self, p):
        g = self.grid(p)
        u0 = g.noise(p["seed"]) if p["initial"] == "noise" else g.mode()
        return g.scene("diffusion", {"u": u0}, {"diffusivity": p["diffusivity"]})

    def t_end(self, p):
        return p["decay_times"] / (p["diffusivity"] * abs(self.grid(p).continuum_eigenvalue()))

    def dt_of(self, p, r):
        return r * self.grid(p).h ** 2 / p["diffusivity"]

    def dts(self, p):
        return [self.dt_of(p, r) for r in DIFFUSION_RS]

    def order_dts(self, p):
        return [self.dt_of(p, r) for r in ORDER_RS]

    def reference_dt(self, p):
        return self.dt_of(p, 0.125)

    # -- reference ----------------------------------------------------------------------------
    def reference(self, p, t):
        g = self.grid(p)
        decay = np.exp(p["diffusivity"] * g.discrete_eigenvalue() * np.asarray(t, float))
        return {"u": np.multiply.outer(decay, g.mode())}

    def energy(self, p, obs):
        """1/2 sum w u^2: the grid's own energy (it decays; a growing one is unstable)."""
        g = self.grid(p)
        u = np.asarray(obs["grid.u"], float)
        return 0.5 * np.sum((u * u * g.weights()).reshape(len(u), -1), axis=1)

    def reference_energy(self, p, t):
        """The semi-discrete mode's energy E0 exp(2 D mu_h t) (None for noise: no closed
        form), so that `energy_drift` is the stepper's energy error in units of E0."""
        if p["initial"] == "noise":
            return None
        return self.energy_scale(p) * np.exp(2.0 * p["diffusivity"] *
                                             self.grid(p).discrete_eigenvalue() *
                                             np.asarray(t, float))

    def energy_scale(self, p):
        return float(self.energy(p, {"grid.u": self.scene(p).part(Grid).fields["u"][None],
                                     "t": np.zeros(1)})[0])

    def factor(self, p, integrator, dt) -> complex:
        """G = R(dt D mu_h): the stepper's exact factor on the mode."""
        z = dt * p["diffusivity"] * self.grid(p).discrete_eigenvalue()
        return complex(heat_stepper(integrator).stability(z))

    def extra_metrics(self, p, obs, observed, reference):
        """err_continuum: max |u - exp(D mu t) phi| at the last sample (space and time error
        against the PDE); decay_rate (1/s): ln(<u, phi> / <phi, phi>) / t at the last sample,
        the measured exponent: exactly ln(G) / dt for a scheme of factor G (D mu_h for the
        semi-discrete solution, D mu for the PDE)."""
        g, t = self.grid(p), np.asarray(obs["t"], float)
        u, phi = np.asarray(obs["grid.u"], float), g.mode()
        exact = math.exp(p["diffusivity"] * g.continuum_eigenvalue() * t[-1]) * phi
        out = {"err_continuum": float(np.max(np.abs(u[-1] - exact)))}
        if p["initial"] == "mode" and t[-1] > 0:
            amplitude = np.sum(u[-1] * phi * g.weights()) / np.sum(phi * phi * g.weights())
            with np.errstate(all="ignore"):
                out["decay_rate"] = float(np.log(amplitude) / t[-1])
        return out

    # -- tolerance ----------------------------------------------------------------------------
    def discrete_deviation(self, p, integrator, dt) -> float:
        """max over the run of |G^n - exp(n z)| (times max|phi| = 1)."""
        steps = np.arange(round(self.t_end(p) / dt) + 1)
        z = dt * p["diffusivity"] * self.grid(p).discrete_eigenvalue()
        gap = self.factor(p, integrator, dt).real ** steps - np.exp(steps * z)
        return float(np.max(np.abs(gap)))

    def roundoff(self, p, integrator, dt) -> tuple[float, int]:
        steps = round(self.t_end(p) / dt)
        r = p["diffusivity"] * dt / self.grid(p).h ** 2
        return 2.0 * steps * stages(integrator) * (1.0 + 4.0 * self.grid(p).dim * r) * EPS, \
            steps

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        deviation = self.discrete_deviation(p, integrator, dt)
        bound, steps = self.roundoff(p, integrator, dt)
        return deviation + bound, (
            f"the scheme's exact factor G = R(h D mu_h) per step on the mode deviates from the "
            f"semi-discrete decay exp(D mu_h t) by at most {deviation:.6g} over the run "
            f"(max|phi| = 1); plus round-off 2 n s (1 + 4 d r) eps = {bound:.3g} (n = {steps} "
            f"steps of s = {stages(integrator)} stencil evaluations, each rounding a point by "
            "at most (1 + 4 d r) eps of the amplitude (the 2d + 1 stencil terms scaled by r); "
            "a stable step contracts every mode, so roundings do not grow; factor 2: the "
            "reference's own evaluation)")

    def stability(self, p):
        """`refsim stress`: the diffusion number y = r = D dt / h^2 on noise over an even
        periodic grid, whose sawtooth mode has the Laplacian's largest eigenvalue d 4/h^2
        exactly; theory: x_R / (4 d), x_R the real stability interval of the stepper's R
        (FTCS, midpoint, Heun 2; RK4 2.785), unbounded for implicit Euler and CN."""
        from refsim.stress.spec import StabilitySpec
        q = {**p, "initial": "noise", "boundary": "periodic"}
        dim, periods, factor = int(p["dim"]), 160, 1e4

        def theory(stepper, settings):
            name = ((settings or {}).get("integrator") or {}).get("name", "")
            try:
                x_r = real_stability_limit(heat_stepper(name))
            except ValueError:
                return math.nan, f"no theory for {name!r}"
            return x_r / (4 * dim), (f"r <= x_R / (4 d), x_R = {x_r:.6g} the real stability "
                                     f"interval of {name}'s R(z); sawtooth eigenvalue d 4/h^2")
        return StabilitySpec(
            name="diffusion number r = D dt / h^2", dt_unit=ModeGrid(q).h ** 2 / p["diffusivity"],
            theory=theory, source="von Neumann: |R(-4 d r)| <= 1 on the sawtooth mode",
            energy_bound=factor * self.energy_scale(q), params={"initial": "noise",
                                                               "boundary": "periodic"},
            periods=periods, quick_periods=16, resolution=self.resolution(q, periods, factor),
            resolution_reason=(
                "past the limit the sawtooth (a share >= 1/(100 N) of the noise's energy) must "
                "grow by F = 1e4 within the judged steps: for FTCS |G| = 4 d r - 1, so the "
                "criterion lands ln(100 N F) / (8 d n) above 1/(2d); the largest such gap of "
                "the explicit steppers offered"))

    def resolution(self, q, periods, factor) -> float:
        """The largest finite-time gap of the explicit steppers (see stability)."""
        g, gaps = ModeGrid(q), []
        need = math.log(100.0 * np.prod(g.shape) * factor)
        for name in ("explicit_euler", "midpoint", "heun", "rk4"):
            stepper = heat_stepper(name)
            y0 = real_stability_limit(stepper) / (4 * g.dim)
            ys = y0 * (1 + np.geomspace(1e-6, 0.5, 4000))
            steps = np.minimum(np.ceil(periods * 2 * math.pi / ys), 10 * periods)
            grow = 2 * steps * np.log(np.abs(stepper.stability(-4 * g.dim * ys)))
            gaps.append(float(ys[np.argmax(grow >= need)] - y0))
        return max(gaps)


CASE = HeatMode()
