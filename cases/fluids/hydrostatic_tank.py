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

from cases.fluids._sph_tank import RHO0, TANK_PARAMS, SPHTankCase
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


CASE = HydrostaticTank()
