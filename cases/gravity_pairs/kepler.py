"""Kepler orbit: two bodies in mutual Newtonian gravity (G = 1, total mass 1, semi-major axis 1),
started at periapsis about their centre of mass at rest at the origin, in the x-y plane (z = 0).

Masses m_1 = 1/(1 + q), m_2 = q/(1 + q), q = `mass_ratio` (default 1e-3, a Sun-Jupiter-like
pair: the light body carries the orbit, the heavy one wobbles by q/(1+q) of it). Variants by
eccentricity: e0.5 (default, one period), e0 (circular), e0.9 (periapsis 0.1, 44 times the
mean motion there), each over `periods` periods.
Reference: the exact two-body solution, Kepler's equation E - e sin E = n t solved by
vectorised Newton to round-off (`_orbits.solve_kepler`; residual <= 4 eps max(1, |M|)), period
T = 2 pi a^1.5 / sqrt(G M) (Murray & Dermott, Solar System Dynamics, 1999, sec. 2.4).
Compared observable `x` (m, both bodies' positions, (T, 2, 3)): the error is the Euclidean norm
over both bodies. Extra metrics: `angular_momentum_drift` max |L - L0| / |L0|,
`runge_lenz_drift` max |e(t) - e(0)| of the eccentricity vector (dimensionless),
`precession_per_orbit` (rad) the turn of the eccentricity vector (the periapsis direction)
from start to end per period run (NaN for e = 0: no periapsis), `momentum_drift`
max |P - P0| / (mu v_max), `period_error` (T_measured - T) / T with T_measured from the last
apoapsis passage (`_orbits.measured_period`: cubic Hermite, floor below 1e-9 T on the default
sampling). `energy_drift` is relative to |E0| = G m_1 m_2 / (2 a).
Tolerance (`_orbits.orbit_bound`): twice Henrici's linearised global error of the named method
(its local error from the exact state at every step, propagated by the orbit's variational
equation), plus round-off.
"""
from __future__ import annotations

import numpy as np

from refsim.case import Case, Param, roundoff_tolerance
from refsim.models.nbody_gravity import GravitySystem, pair_jacobian
from refsim.scene import Particles, Scene
from refsim.scene.gravity_pairs import GravityPairs

from ._orbits import (
    invariants_of,
    kepler_period,
    measured_period,
    orbit_bound,
    sampled_steps,
    two_body_state,
    vector_drift,
)

G, SEMI_MAJOR, TOTAL_MASS = 1.0, 1.0, 1.0
STEPS_PER_PERIOD = (40, 126, 400)  # the timed dt sweep (a decade of dt), as steps per period
ORDER_STEPS_PER_PERIOD = (1260,)  # untimed, for the order fit: with 126 and 400 a decade
# above the coarsest (T/40, where most methods are unresolved and the fit starts pre-asymptotic)


def masses(p) -> np.ndarray:
    q = p["mass_ratio"]
    return np.array([1.0, q]) * TOTAL_MASS / (1.0 + q)


def period(p) -> float:
    return float(kepler_period(SEMI_MAJOR, G, TOTAL_MASS))


def periapsis_rate(p) -> float:
    """Largest angular rate of the relative orbit (rad/s): n sqrt(1 + e) / (1 - e)^1.5."""
    e = p["e"]
    return 2.0 * np.pi / period(p) * np.sqrt(1.0 + e) / (1.0 - e) ** 1.5


class Kepler(Case):
    name = "kepler"
    description = ("two-body Kepler orbit (G = M = a = 1) from periapsis: exact solution by "
                   "Kepler's equation; E, L and the Runge-Lenz vector conserved")
    tags = ("particle_fields", "gravity", "orbit", "exact")
    observable, units = "x", "m"
    params = {
        "e": Param(0.5, 0.0, 0.95, "eccentricity"),
        "mass_ratio": Param(1e-3, 0.0, 1.0, "q = m_2 / m_1", low_inclusive=False),
        "periods": Param(1.0, 0.0, 1e3, "run length in periods", low_inclusive=False),
    }
    variants = {"e0.5": {}, "e0": {"e": 0.0}, "e0.9": {"e": 0.9}}
    quick_variants = ("e0.5",)
    default_variants = ("e0.5",)
    samples = 128  # observations per run (the period is measured at an apoapsis passage)

    def scene(self, p):
        x, v = two_body_state(np.zeros(1), SEMI_MAJOR, p["e"], G, masses(p))
        bodies = Particles(mass=masses(p), position=x[0], velocity=v[0])
        return Scene(parts=(bodies, GravityPairs(G=G, softening=0.0)))

    def bodies(self, p):
        return 2

    def t_end(self, p):
        return p["periods"] * period(p)

    def dts(self, p):
        return [period(p) / k for k in STEPS_PER_PERIOD]

    def order_dts(self, p):
        return [period(p) / k for k in ORDER_STEPS_PER_PERIOD]

    def reference_dt(self, p):
        return period(p) / STEPS_PER_PERIOD[-1]

    def motion_scale(self, p):
        return SEMI_MAJOR * (1.0 + p["e"])  # apoapsis distance of the relative orbit

    def error_floor(self, p):
        return self._roundoff(p, min(self.dts(p)))[0]

    def observables(self, p, obs):
        x, v = np.asarray(obs["x"], float), np.asarray(obs["v"], float)
        r = x[:, 1] - x[:, 0]
        return {"x": x, "v": v, "separation": np.linalg.norm(r, axis=-1)}

    def reference(self, p, t):
        x, v = two_body_state(t, SEMI_MAJOR, p["e"], G, masses(p))
        return {"x": x, "v": v, "separation": np.linalg.norm(x[:, 1] - x[:, 0], axis=-1)}

    def energy(self, p, obs):
        return invariants_of(obs, masses(p), G)["energy"]

    def energy_scale(self, p):
        m1, m2 = masses(p)
        return G * m1 * m2 / (2.0 * SEMI_MAJOR)

    def extra_metrics(self, p, obs, observed, reference):
        inv = invariants_of(obs, masses(p), G)
        lenz, t = inv["runge_lenz"], np.asarray(obs["t"], float)
        m1, m2 = masses(p)
        mu_v = m1 * m2 / (m1 + m2) * periapsis_rate(p) * SEMI_MAJOR * (1.0 - p["e"])
        x, v = observed["x"], observed["v"]
        measured = measured_period(t, x[:, 1] - x[:, 0], v[:, 1] - v[:, 0])
        turn = np.nan
        if p["e"] > 0:
            ang = np.arctan2(lenz[:, 1], lenz[:, 0])
            turn = float(np.angle(np.exp(1j * (ang[-1] - ang[0]))) * period(p) / t[-1])
        return {"angular_momentum_drift": vector_drift(inv["angular_momentum"],
                                                       np.linalg.norm(inv["angular_momentum"][0])),
                "runge_lenz_drift": vector_drift(lenz, 1.0),
                "precession_per_orbit": turn,
                "momentum_drift": vector_drift(inv["momentum"], mu_v),
                "period_error": (measured - period(p)) / period(p)}

    def _roundoff(self, p, dt):
        """S = 2 (1 + e) a: rounding both bodies' positions and velocities (|v| t-scaled by the
        periapsis rate) once; the phase error a rounding starts grows as 1 + 1.5 w t (the
        energy-period coupling at the mean motion n = 2 pi / T: dlnT/dlnE = -1.5)."""
        steps = int(round(self.t_end(p) / dt))
        bound, reason = roundoff_tolerance(steps, 2.0 * self.motion_scale(p))
        growth = 1.0 + 1.5 * 2.0 * np.pi / period(p) * self.t_end(p)
        return bound * growth, f"{reason}, times 1 + 1.5 n t = {growth:.3g}"

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        t_end = self.t_end(p)
        roundoff, roundoff_reason = self._roundoff(p, dt)
        tol, reason = orbit_bound(
            integrator, GravitySystem(masses(p), G), lambda t: flat_state(p, t),
            lambda x: pair_jacobian(x.reshape(len(x), 2, 3), masses(p), G), dt,
            sampled_steps(t_end, self.sample_dt(p), dt))
        return tol + roundoff, reason + roundoff_reason


def flat_state(p, t):
    """(x, v) of both bodies at times t, flat (T, 6): the exact solution."""
    x, v = two_body_state(np.asarray(t, float), SEMI_MAJOR, p["e"], G, masses(p))
    return x.reshape(len(x), -1), v.reshape(len(v), -1)


CASE = Kepler()
