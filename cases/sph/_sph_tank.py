"""What the SPH tank cases share: a 2D block of water of width a and depth H at rest in a tank,
its WCSPH settings, time step, energy and the fluid metrics.

Model defaults (refsim.models.sph, the same in taichi): Tait equation of state with the sound
speed c0 = sqrt(2 g H) / Mach (weakly compressible, Monaghan 1994), Monaghan artificial
viscosity alpha = 0.02 (chosen before any comparison, never fitted), delta-SPH density
diffusion delta = 0.1 (Antuono et al. 2010's value), and a gauge pressure that may go negative
(`pressure=tension`, as in delta-SPH) or is clamped at zero (`pressure=clamped`). Walls: dummy
particles (Adami, Hu & Adams, "A generalized wall boundary condition for smoothed particle
hydrodynamics", J. Comput. Phys. 231, 2012); `walls=no_slip` lets the artificial viscosity act
between fluid and wall particles too (a numerical no-slip bed), `walls=free_slip` acts through
pressure only. dt = cfl h / c0, one dt per run (no sweep: no order in dt is measured).

Metrics of every tank: `mass_drift` (mass that left the tank, / total), `density_dev_max` /
`density_dev_mean` (|rho/rho0 - 1| over the fluid, max and mean over the run), `min_spacing`
(closest two fluid particles over the run, / dx: pairing shows here), mechanical energy
(kinetic + potential; `energy_drift` is its largest change over the column's potential energy
M g H / 2).
"""
from __future__ import annotations

import numpy as np

from refsim.case import Case, Param
from refsim.scene import FluidBlock, Scene

INCH = 0.0254
RHO0 = 1000.0  # kg/m^3, water

TANK_PARAMS = {
    "a": Param(2.25 * INCH, 0.0, 10.0, "column width a (m)", low_inclusive=False),
    "resolution": Param(20, 4, 400, "a / dx"),
    "g": Param(9.81, 0.0, 1e3, "m/s^2", low_inclusive=False),
    "mach": Param(0.1, 0.0, 0.5, "sqrt(2 g H) / c0", low_inclusive=False),
    "alpha": Param(0.02, 0.0, 1.0, "Monaghan artificial viscosity"),
    "walls": Param("no_slip", choices=("no_slip", "free_slip")),
    "delta": Param(0.1, 0.0, 1.0, "delta-SPH density diffusion (Antuono 2010: 0.1)"),
    "pressure": Param("tension", choices=("tension", "clamped")),
    "smoothing": Param(1.3, 1.0, 2.0, "h / dx"),
    "cfl": Param(0.25, 0.0, 0.5, "dt = cfl h / c0", low_inclusive=False),
    "t_end_T": Param(9.5, 0.0, 100.0, "duration in T = t sqrt(2g/a)", low_inclusive=False),
}


class SPHTankCase(Case):
    """A block of water [0, a] x [0, depth(p)] in a tank [0, tank_width(p)] x [0, 1.25 depth]
    under gravity -y. A subclass supplies `depth(p)` and `tank_width(p)`."""
    divergence_factor = 10.0
    tolerance_norm = "err_rms"
    order_meaningful = False  # one dt per run, set by the CFL condition
    # the references are the experiment (Martin & Moyce's front) and the continuum (rho0 g H):
    # the particle lattice's own front and bed pressure at t = 0 differ from them by its
    # discretisation, not by the engine's start
    initial_state_is_reference = False

    def depth(self, p) -> float:
        raise NotImplementedError

    def tank_width(self, p) -> float:
        raise NotImplementedError

    def validate(self, overrides=None):
        p = super().validate(overrides)
        p["resolution"] = int(p["resolution"])
        return p

    # -- geometry ----------------------------------------------------------------------------
    def spacing(self, p):
        return p["a"] / p["resolution"]

    def bodies(self, p):
        return p["resolution"] * int(round(p["resolution"] * self.depth(p) / p["a"]))

    def sound_speed(self, p):
        return np.sqrt(2 * p["g"] * self.depth(p)) / p["mach"]

    def time_unit(self, p):
        return np.sqrt(2 * p["g"] / p["a"])  # T = t * this

    def scene(self, p):
        depth = self.depth(p)
        fluid = FluidBlock(lower=(0.0, 0.0), upper=(p["a"], depth), spacing=self.spacing(p),
                           tank_width=self.tank_width(p), tank_height=1.25 * depth,
                           density=RHO0, sound_speed=self.sound_speed(p),
                           viscosity_alpha=p["alpha"], smoothing=p["smoothing"],
                           no_slip=p["walls"] == "no_slip", delta=p["delta"],
                           tension=p["pressure"] == "tension")
        return Scene(parts=(fluid,), gravity=(0.0, -p["g"], 0.0), dim=2)

    # -- time --------------------------------------------------------------------------------
    def t_end(self, p):
        return p["t_end_T"] / self.time_unit(p)

    def reference_dt(self, p):
        return p["cfl"] * p["smoothing"] * self.spacing(p) / self.sound_speed(p)

    def dts(self, p):
        return [self.reference_dt(p)]

    def sample_dt(self, p):
        return self.t_end(p) / 100

    # -- energy and metrics ------------------------------------------------------------------
    def energy(self, p, obs):
        m = obs["mass"]
        return (0.5 * np.einsum("tj,tjk,tjk->t", m, obs["v"], obs["v"])
                + p["g"] * np.einsum("tj,tj->t", m, obs["x"][:, :, 1]))

    def energy_scale(self, p):
        mass = RHO0 * p["a"] * self.depth(p)
        return mass * p["g"] * self.depth(p) / 2

    def fluid_metrics(self, p, obs) -> dict:
        """mass_drift, density_dev_max, density_dev_mean and min_spacing of a whole run."""
        dev = np.abs(obs["rho"] / RHO0 - 1.0)
        x = obs["x"]
        inside = ((x[..., 0] >= -1e-9) & (x[..., 0] <= self.tank_width(p) + 1e-9)
                  & (x[..., 1] >= -1e-9))
        kept = np.einsum("tj,tj->t", obs["mass"], inside)
        return {"mass_drift": float(np.max(np.abs(kept - kept[0])) / kept[0]),
                "density_dev_max": float(dev.max()), "density_dev_mean": float(dev.mean()),
                "min_spacing": self.min_spacing(p, x)}

    def min_spacing(self, p, x):
        """Smallest distance between two fluid particles over the run, / dx: particles pairing
        up (the tensile instability where the pressure is negative, or particles squeezed at a
        wall) show here; a healthy WCSPH flow keeps it above ~0.5."""
        from scipy.spatial import cKDTree
        nearest = [cKDTree(xk).query(xk, k=2)[0][:, 1].min() for xk in x if len(xk) > 1]
        return float(min(nearest) / self.spacing(p)) if nearest else float("nan")
