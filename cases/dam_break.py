"""Dam break: a 2D water column of width a and height 2a (n^2 = 2) against the left wall of a
tank collapses at t = 0; the surge front is compared with Martin & Moyce (1952), Table 2.

Reference: `cases/data/martin_moyce_1952_table2_front_n2eq2.csv` (its header gives the source):
Z = x/a, the front's distance from the wall (Z = 1 at t = 0), against T = t sqrt(2 g / a). The
experiment's time origin was fitted (runs aligned at T = 1.19, Z = 1.44; the gate took time to
open), so one time shift s is fitted by least squares, |s| <= 0.3, and reported (`time_shift`):
the simulated front at T - s is compared with the measurement at T.

Front definition: the largest x among fluid particles that are on the bed (y < 3 dx) and belong
to the bulk (at least 3 fluid neighbours within the kernel support 2h). The single furthest
particle is not used: spray and stray particles ahead of the surge depend on resolution and
say nothing about the front the experimenters photographed; a particle with 3 neighbours at
the bed is part of the sheet of water, even where the sheet is one particle thick.

Metrics: `front_err_rms` (RMS of Z errors over the table's points inside the run, after the
shift; also err_rms; err_max is the largest |dZ|), `time_shift` (T units), `mass_drift` (mass
that left the tank, / total), `density_dev_max` / `density_dev_mean` (|rho/rho0 - 1| over the
fluid, max and mean over the run), `min_spacing` (closest two fluid particles over the run,
/ dx: pairing shows here), mechanical energy (kinetic + potential; `energy_drift` is its
largest change over the column's potential energy M g H / 2).

Model defaults (refsim.models.sph, the same in taichi): alpha = 0.02 (chosen before any
comparison, never fitted), delta-SPH diffusion delta = 0.1 (Antuono et al. 2010's value),
and the pressure is a gauge pressure that may go negative (`pressure=tension`, as in
delta-SPH; real water carries a few kPa below atmospheric without cavitating). With
`pressure=clamped` (variant `res40_clamped`) nothing pulls a stretched region back: the
continuity density of the one-particle sheet at the tip falls by up to 10 % (a/dx = 40),
while with tension it stays within 0.6 %; tension's price is particle pairing where the
pressure is negative (`min_spacing` down to ~0.01-0.05 dx, in the rarefaction behind the
collapsing column and at the tip: the tensile instability), which the clamp limits to ~0.14
dx at the tip.

Walls: dummy particles (Adami 2012). By default the artificial viscosity also acts between
fluid and wall particles: a numerical no-slip bed whose effective viscosity alpha c0 h / 8
(7e-5 m^2/s at a/dx = 40, 70 x water's) slows the thin surge front, less as dx shrinks.
`walls=free_slip` (variant `res40_free_slip`) acts through pressure only: the inviscid limit,
whose front runs at Ritter's dZ/dT = 2, faster than the experiment's 1.66 late on (bed
friction, the gate and the contact line in the experiment). The front error is set by that
bed friction, not by a discretisation error that shrinks as dx: halving alpha does what
halving dx does (nu_eff ~ alpha h; measured front_err_rms 0.423 at a/dx = 20, 0.275 at 20
with alpha / 2, 0.235 at 40; 0.101 at 40 with alpha / 2, 0.109 at 80), and as h -> 0 at
fixed alpha the no-slip front tends to the free-slip (inviscid) one, which moves away from
the data as dx shrinks (0.300 at a/dx = 40, 0.391 at 80, the shift at its bound): the no-slip
sequence 0.42, 0.24, 0.11 (a/dx = 20, 40, 80) passes the data on its way there. Study:
reports/dam_break_study/.

Sub-case `hydrostatic`: a closed tank (width a, depth H = a), no release. After settling (the
second half of the run) the bed pressure, averaged over that half (WCSPH pressure carries
acoustic noise, reported as `bed_pressure_noise`, its standard deviation / rho0 g H), must be
within 5 % of rho0 g H (err_* = |<p_bed> / (rho0 g H) - 1|), velocities near zero
(`velocity_max`, / sqrt(g H)) and the density drift under 1 % (`density_drift`).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from refsim.case import Case, Param
from refsim.scene import FluidBlock, Scene

DATA = Path(__file__).parent / "data" / "martin_moyce_1952_table2_front_n2eq2.csv"
INCH = 0.0254


def martin_moyce():
    """(T, Z) of the surge front from the data file."""
    rows = [line for line in DATA.read_text().splitlines() if line and not line.startswith("#")]
    assert rows[0].replace(" ", "") == "T,Z", f"unexpected header in {DATA.name}: {rows[0]}"
    table = np.array([[float(v) for v in line.split(",")] for line in rows[1:]])
    return table[:, 0], table[:, 1]


def clock_spread_rms(fraction):
    """RMS change of the measured Z(T) if the experiment's clock ran `fraction` fast: how far
    the experiment itself moves when its runs spread by that fraction in T (issue 5: the runs
    spread 5-10 % in T early on): 0.35 at 5 %, 0.66 at 10 %."""
    T, Z = martin_moyce()
    inside = T * (1 + fraction) <= T[-1]
    return float(np.sqrt(np.mean((np.interp(T[inside] * (1 + fraction), T, Z) - Z[inside]) ** 2)))


class DamBreak(Case):
    name = "dam_break"
    description = "2D water column (n^2 = 2) collapse; WCSPH front vs Martin & Moyce (1952)"
    tags = ("fluid", "sph", "experimental")
    observable, units = "front", "Z = x / a"
    params = {
        "layout": Param("release", choices=("release", "hydrostatic")),
        "a": Param(2.25 * INCH, 0.0, 10.0, "column width a (m)", low_inclusive=False),
        "resolution": Param(20, 4, 400, "a / dx"),
        "tank_length": Param(16.0, 2.0, 100.0, "tank length / a"),
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
    variants = {"res20": {}, "res40": {"resolution": 40}, "res80": {"resolution": 80},
                "res40_free_slip": {"resolution": 40, "walls": "free_slip"},
                "res40_clamped": {"resolution": 40, "pressure": "clamped"},
                "hydrostatic": {"layout": "hydrostatic", "t_end_T": 20.0}}
    quick_variants = ("res20",)
    default_variants = ("res20", "hydrostatic")  # res40 (minutes) is run by name
    divergence_factor = 10.0
    tolerance_norm = "err_rms"  # the front's RMS error over the table (issue 5)

    # -- geometry ----------------------------------------------------------------------------
    def validate(self, overrides=None):
        p = super().validate(overrides)
        p["resolution"] = int(p["resolution"])
        return p

    def depth(self, p):
        return 2 * p["a"] if p["layout"] == "release" else p["a"]

    def spacing(self, p):
        return p["a"] / p["resolution"]

    def observed(self, p):
        if p["layout"] == "hydrostatic":
            return "settled bed pressure <p_bed>", "of rho0 g H"
        return self.observable, self.units

    def bodies(self, p):
        return p["resolution"] * int(round(p["resolution"] * self.depth(p) / p["a"]))

    def sound_speed(self, p):
        return np.sqrt(2 * p["g"] * self.depth(p)) / p["mach"]

    def time_unit(self, p):
        return np.sqrt(2 * p["g"] / p["a"])  # T = t * this

    def scene(self, p):
        a, depth = p["a"], self.depth(p)
        width = p["tank_length"] * a if p["layout"] == "release" else a
        fluid = FluidBlock(lower=(0.0, 0.0), upper=(a, depth), spacing=self.spacing(p),
                           tank_width=width, tank_height=1.25 * depth, density=1000.0,
                           sound_speed=self.sound_speed(p), viscosity_alpha=p["alpha"],
                           smoothing=p["smoothing"], no_slip=p["walls"] == "no_slip",
                           delta=p["delta"], tension=p["pressure"] == "tension")
        return Scene(bodies=(), fluid=fluid, gravity=(0.0, -p["g"], 0.0), dim=2,
                     meta={"layout": p["layout"]})

    # -- time --------------------------------------------------------------------------------
    def t_end(self, p):
        return p["t_end_T"] / self.time_unit(p)

    def reference_dt(self, p):
        return p["cfl"] * p["smoothing"] * self.spacing(p) / self.sound_speed(p)

    def dts(self, p):
        return [self.reference_dt(p)]

    def sample_dt(self, p):
        return self.t_end(p) / 100

    def motion_scale(self, p):
        return p["tank_length"] if p["layout"] == "release" else 1.0

    # -- observables -------------------------------------------------------------------------
    def observables(self, p, obs):
        t = np.asarray(obs["t"])
        if p["layout"] == "hydrostatic":
            return {"bed_pressure": np.array([self._bed_pressure(p, obs, k)
                                              for k in range(len(t))]) / self._p_bed(p),
                    "T": t * self.time_unit(p)}
        return {"front": np.array([self.front(p, obs["x"][k]) for k in range(len(t))]),
                "T": t * self.time_unit(p)}

    def front(self, p, x):
        """Z of the surge front (see the module docstring for the definition)."""
        from scipy.spatial import cKDTree
        dx = self.spacing(p)
        bed = x[:, 1] < 3 * dx
        if not bed.any():
            return 1.0
        counts = cKDTree(x).query_ball_point(x[bed], 2 * p["smoothing"] * dx,
                                             return_length=True) - 1
        bulk = x[bed][counts >= 3]
        return float(bulk[:, 0].max() / p["a"]) if len(bulk) else 1.0

    def _p_bed(self, p):
        return 1000.0 * p["g"] * self.depth(p)

    def _bed_pressure(self, p, obs, k):
        """Mean pressure of the bottom fluid layer plus the hydrostatic head below it."""
        from refsim.models.sph import tait_pressure
        x, rho = obs["x"][k], obs["rho"][k]
        dx = self.spacing(p)
        layer = x[:, 1] < dx
        pressure = tait_pressure(rho[layer], 1000.0, self.sound_speed(p))
        return float(np.mean(pressure + 1000.0 * p["g"] * x[layer, 1]))

    def reference(self, p, t):
        return {}

    def error(self, p, observed, reference):
        if p["layout"] == "hydrostatic":  # the settled (time-averaged) bed pressure
            T = observed["T"]
            return np.array([abs(np.mean(observed["bed_pressure"][T >= 0.5 * T[-1]]) - 1.0)])
        shift, dz = self.fit(p, observed["T"], observed["front"])
        return np.abs(dz)

    def fit(self, p, T_sim, Z_sim):
        """Least-squares time shift s (|s| <= 0.3) and the residuals Z_sim(T - s) - Z."""
        from scipy.optimize import minimize_scalar
        T, Z = martin_moyce()

        def residuals(s):
            inside = (T - s >= T_sim[0]) & (T - s <= T_sim[-1])
            return np.interp(T[inside] - s, T_sim, Z_sim) - Z[inside]

        best = minimize_scalar(lambda s: np.mean(residuals(s) ** 2), bounds=(-0.3, 0.3),
                               method="bounded", options={"xatol": 1e-6})
        return float(best.x), residuals(best.x)

    # -- energy and extra metrics ------------------------------------------------------------
    def energy(self, p, obs):
        m = obs["mass"]
        return (0.5 * np.einsum("tj,tjk,tjk->t", m, obs["v"], obs["v"])
                + p["g"] * np.einsum("tj,tj->t", m, obs["x"][:, :, 1]))

    def energy_scale(self, p):
        mass = 1000.0 * p["a"] * self.depth(p)
        return mass * p["g"] * self.depth(p) / 2

    def extra_metrics(self, p, obs, observed, reference):
        dev = np.abs(obs["rho"] / 1000.0 - 1.0)
        width = p["tank_length"] * p["a"] if p["layout"] == "release" else p["a"]
        x = obs["x"]
        inside = (x[..., 0] >= -1e-9) & (x[..., 0] <= width + 1e-9) & (x[..., 1] >= -1e-9)
        kept = np.einsum("tj,tj->t", obs["mass"], inside)
        out = {"mass_drift": float(np.max(np.abs(kept - kept[0])) / kept[0]),
               "density_dev_max": float(dev.max()), "density_dev_mean": float(dev.mean()),
               "min_spacing": self.min_spacing(p, x)}
        if p["layout"] == "release":
            shift, dz = self.fit(p, observed["T"], observed["front"])
            out.update(front_err_rms=float(np.sqrt(np.mean(dz ** 2))), time_shift=shift)
        else:
            late = observed["T"] >= 0.5 * observed["T"][-1]
            speed = np.linalg.norm(obs["v"][late], axis=-1)
            bed = observed["bed_pressure"][late]
            out.update(bed_pressure_noise=float(np.std(bed)),
                       velocity_max=float(speed.max() / np.sqrt(p["g"] * self.depth(p))),
                       density_drift=float(abs(np.mean(obs["rho"][-1]) / np.mean(
                           obs["rho"][0]) - 1.0)))
        return out

    def min_spacing(self, p, x):
        """Smallest distance between two fluid particles over the run, / dx: particles pairing
        up (the tensile instability where the pressure is negative, or particles squeezed at a
        wall) show here; a healthy WCSPH flow keeps it above ~0.5."""
        from scipy.spatial import cKDTree
        nearest = [cKDTree(xk).query(xk, k=2)[0][:, 1].min() for xk in x if len(xk) > 1]
        return float(min(nearest) / self.spacing(p)) if nearest else float("nan")

    def target_error(self, p):
        """0.15 RMS in Z (issue 5's bar, inside the experiment's own spread); 5 % bed pressure
        for the hydrostatic tank."""
        return 0.05 if p["layout"] == "hydrostatic" else 0.15

    # -- tolerance ---------------------------------------------------------------------------
    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        if p["layout"] == "hydrostatic":
            return 0.05, "bed pressure within 5 % of rho0 g H after settling (issue 5)"
        return 0.15, ("RMS front error in Z within 0.15 (issue 5's bar: inside the experimental "
                      "runs' own 5-10 % spread in T), at every resolution: the error is not a "
                      "discretisation error that shrinks as dx (it follows the numerical bed "
                      "friction alpha c0 h / 8, see the case docstring)")


CASE = DamBreak()
