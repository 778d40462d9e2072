"""Hydrostatic tank: water at rest in a closed tank (width a, depth H = a), no release; after
settling, the bed pressure must equal rho0 g H.

Reference: hydrostatics, p(y) = rho0 g (H - y); the standard first check of an SPH wall model
(Adami, Hu & Adams, J. Comput. Phys. 231, 2012: its hydrostatic water column test). After
settling (the second half of the run) the bed pressure, averaged over that half (WCSPH pressure
carries acoustic noise, reported as `bed_pressure_noise`, its standard deviation / rho0 g H),
must be within 5 % of rho0 g H (err_* = |<p_bed> / (rho0 g H) - 1|), velocities near zero
(`velocity_max`, / sqrt(g H)) and the density drift under 1 % (`density_drift`). The bed
pressure is the mean Tait pressure of the bottom fluid layer plus the hydrostatic head below
it. Model, walls and the shared metrics: cases.fluids._sph_tank.
"""
from __future__ import annotations

import numpy as np

from refsim_cases.sph._sph_tank import RHO0, TANK_PARAMS, SPHTankCase
from refsim.case import Param


class HydrostaticTank(SPHTankCase):
    name = "hydrostatic_tank"
    description = "2D water at rest in a closed tank; WCSPH bed pressure vs rho0 g H"
    tags = ("fluid", "sph", "exact")
    observable, units = "settled bed pressure <p_bed>", "of rho0 g H"
    params = {**TANK_PARAMS,
              "t_end_T": Param(20.0, 0.0, 100.0, "duration in T = t sqrt(2g/a)",
                               low_inclusive=False)}
    variants = {"hydrostatic": {}}
    quick_variants = ()  # not in a --quick run (as before the split)

    def depth(self, p):
        return p["a"]

    def tank_width(self, p):
        return p["a"]

    def motion_scale(self, p):
        return 1.0

    def target_error(self, p):
        """5 % of the bed pressure."""
        return 0.05

    def bed_pressure(self, p, x, rho):
        """Mean pressure of the bottom fluid layer plus the hydrostatic head below it (Pa), of
        one sample's positions x (n, 2) and densities rho (n,)."""
        from refsim.models.sph import tait_pressure
        layer = x[:, 1] < self.spacing(p)
        pressure = tait_pressure(rho[layer], RHO0, self.sound_speed(p))
        return float(np.mean(pressure + RHO0 * p["g"] * x[layer, 1]))

    def observables(self, p, obs):
        t = np.asarray(obs["t"])
        p_bed = RHO0 * p["g"] * self.depth(p)
        return {"bed_pressure": np.array([self.bed_pressure(p, obs["x"][k], obs["rho"][k])
                                          for k in range(len(t))]) / p_bed,
                "T": t * self.time_unit(p)}

    def reference(self, p, t):
        return {}  # the bed pressure's reference, 1 (of rho0 g H), enters through `error`

    def error(self, p, observed, reference):
        """|<p_bed> / (rho0 g H) - 1| over the second half of the run (one value)."""
        T = observed["T"]
        return np.array([abs(np.mean(observed["bed_pressure"][T >= 0.5 * T[-1]]) - 1.0)])

    def extra_metrics(self, p, obs, observed, reference):
        out = self.fluid_metrics(p, obs)
        late = observed["T"] >= 0.5 * observed["T"][-1]
        speed = np.linalg.norm(obs["v"][late], axis=-1)
        out.update(bed_pressure_noise=float(np.std(observed["bed_pressure"][late])),
                   velocity_max=float(speed.max() / np.sqrt(p["g"] * self.depth(p))),
                   density_drift=float(abs(np.mean(obs["rho"][-1]) / np.mean(
                       obs["rho"][0]) - 1.0)))
        return out

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        return 0.05, "bed pressure within 5 % of rho0 g H after settling (issue 5)"

    def stability(self, p):
        """`refsim stress`: the CFL number y = c0 dt / h of the kick-drift-kick WCSPH step;
        theory `kdk_cfl_limit` (von Neumann analysis of that step on the particle lattice).
        A run is judged over P acoustic crossings of the tank (a / c0 each, so a/h / y steps)
        and is stable while |E - E(0)| < divergence_factor x M g H / 2 (the case's own
        divergence bound), the state finite."""
        from refsim.stress.spec import StabilitySpec, integrator_family
        limit = kdk_cfl_limit(p["smoothing"], p["delta"])

        def theory(stepper, settings):
            family = integrator_family(settings)
            if family.startswith("kick-drift-kick"):
                return limit, KDK_THEORY
            return np.nan, f"no theory for the integrator family {family!r}"
        return StabilitySpec(
            name="CFL number c0 dt / h", dt_unit=p["smoothing"] * self.spacing(p) /
            self.sound_speed(p), theory=theory, source=KDK_THEORY,
            energy_bound=self.divergence_factor * self.energy_scale(p),
            cycle=p["resolution"] / p["smoothing"], periods=200, quick_periods=50,
            resolution=0.03 * limit, resolution_reason=KDK_RESOLUTION)


KDK_THEORY = (
    "von Neumann analysis of refsim.models.sph.WCSPH.step (kick-drift-kick, continuity "
    "density drifted by the trapezoid, delta-SPH diffusion explicit) linearised about rest on "
    "the infinite square lattice (p = c0^2 (rho - rho0)): a density wave e^{ik.x} obeys "
    "R'' = -(c0 V |G(k)|)^2 R, G(k) = sum_j sin(k.r_j) grad W(r_j) (the SPH dispersion "
    "relation; Morris 1996, Dehnen & Aly 2012), damped by the diffusion rate 2 delta h c0 V "
    "sum_j -F(r_j) (1 - cos k.r_j); the limit is the largest c0 dt / h at which the 2x2 step "
    "matrix of every k has spectral radius <= 1 (without diffusion omega dt <= 2, leapfrog's "
    "limit)")
KDK_RESOLUTION = (
    "3 % of the theory: the analysis leaves out the artificial viscosity (alpha = 0.02), the "
    "hydrostatic pre-pressure (p / rho0 c0^2 <= Mach^2 / 2), the walls and free surface (the "
    "lattice is infinite there), and the finite-time criterion lands above a limit where the "
    "growth per step is slow")


def kdk_cfl_limit(smoothing: float, delta: float, k_points: int = 121) -> float:
    """Largest c0 dt / h at which the linearised KDK step is stable for every lattice wave
    (dx = 1, rho0 = c0 = 1; bisection to 1e-6); see KDK_THEORY."""
    from refsim.models.sph import wendland_gradient_factor
    reach = int(np.ceil(2 * smoothing)) + 1
    grid = np.arange(-reach, reach + 1, dtype=float)
    offsets = np.stack(np.meshgrid(grid, grid), -1).reshape(-1, 2)
    dist = np.linalg.norm(offsets, axis=1)
    offsets, dist = offsets[dist > 0], dist[dist > 0]
    factor = wendland_gradient_factor(dist, smoothing)
    k = np.linspace(0.0, np.pi, k_points)
    waves = np.stack(np.meshgrid(k, k), -1).reshape(-1, 2)
    phase = waves @ offsets.T
    gradient = np.linalg.norm(np.sin(phase) @ (factor[:, None] * offsets), axis=1)
    diffusion = 2.0 * delta * smoothing * ((1.0 - np.cos(phase)) @ -factor)

    def stable(cfl):
        a, b = cfl * smoothing * gradient, cfl * smoothing * diffusion  # omega dt, D dt
        # (R, u) -> u+ = u + i a/2 R; R' = (1 - b) R + i a u+; u' = u+ + i a/2 R'
        r_new = np.stack([(1 - b) - 0.5 * a * a, 1j * a], -1)
        u_new = np.stack([0.5j * a * (2 - b) - 0.25j * a ** 3, 1 - 0.5 * a * a], -1)
        radius = np.abs(np.linalg.eigvals(np.stack([r_new, u_new], -2))).max()
        return radius <= 1.0 + 1e-12
    lo, hi = 0.0, 4.0
    while hi - lo > 1e-6:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


CASE = HydrostaticTank()
