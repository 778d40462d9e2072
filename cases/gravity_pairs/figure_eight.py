"""Figure-eight three-body choreography (Chenciner & Montgomery, Annals of Mathematics 152
(2000) 881; initial conditions of Simo, as quoted in
docs/models.md#fields-kepler-and-figure-eight): three equal masses (G = m = 1) chase each other
around one figure-eight curve in the x-y plane (z = 0); run with
m = 2 kg, G = 0.5 (G m = 1, the same orbit: a missing mass or G factor shows):
x1 = -x2 = (0.97000436, -0.24308753), x3 = 0, v3 = (-0.93240737, -0.86473146),
v1 = v2 = -v3 / 2, period T = 6.32591398. Variants: `one_period` (default) and
`hundred_periods` (by name: energy drift over 100 periods, symplectic bounded against RK4's
secular growth; the extra metric `energy_growth` tells them apart).

Reference: a converged solution independent of the engine under test: scipy's DOP853
(`solve_ivp`, an eighth-order method of another implementation) at rtol 2.5e-14 (atol 2.5e-17;
scipy's floor is 100 eps) on the case's own three-body accelerations (`accelerations`, not
refsim's gravity model), its dense output on a grid of REF_POINTS_PER_PERIOD points per
period, between them the quintic Hermite interpolant of x, v, a at both ends. Its error over
one period: interpolation 1.2e-11 m (at the midpoints, against one dopri5_adaptive step at
rtol 1e-14 from the node) plus integration 4.9e-13 m (against refsim's dopri5_adaptive at rtol
1e-14 landing on the grid points):
REFERENCE_ERROR = 5e-11 m bounds their sum. Over P periods the integration error grows: a
local error changes the energy, hence the period, and the phase error that follows grows with
t on top of the energy error's own growth: at most as t^2, so `reference_error(P)` =
REFERENCE_ERROR max(1, P)^2 (measured against dopri5_adaptive at rtol 1e-14: 3.5e-11 m over 10
periods, 2.7e-9 m over 100, under its bounds 5e-9 and 5e-7 m; tests/cases/test_figure_eight.py
checks ten periods). DOP853 takes 10-15 s of CPU for 100 periods where refsim's dopri5_adaptive
at rtol 1e-12, the reference before, took 48-58 s (back to back) and was 1.4e-7 m off.
Compared observable `x` (m, the three positions,
(T, 3, 3)), error = Euclidean norm over the bodies.
The 8-digit initial conditions do not close the orbit exactly: the return error
|x(T) - x(0)| of the converged solution is RETURN_FLOOR (measured 5.03e-8 m with refsim's
dopri5_adaptive at rtol 1e-13);
the extra metric `return_error` (after whole periods only) is meaningful only above it.
Extra metrics: `return_error` (m), `momentum_drift` max |P - P0| / (sum m |v|)(0),
`angular_momentum_drift` max |L - L0| / (sum m |x| |v|)(0) (L0 is 0 to the ICs' digits, so
an absolute scale), `energy_growth` max |E - E0| over the second half of the run / over the
first half (about 1: bounded, symplectic; about 2: linear secular drift).
Tolerance (`_orbits.orbit_bound`): twice Henrici's linearised global error of the named method
along the converged orbit, plus round-off and REFERENCE_ERROR.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from refsim.case import Case, Param, roundoff_tolerance
from refsim.models.nbody_gravity import GravitySystem, pair_jacobian
from refsim.scene import Particles, Scene
from refsim.scene.gravity_pairs import GravityPairs

from ._orbits import invariants_of, orbit_bound, sampled_steps, vector_drift

PERIOD = 6.32591398
X1 = (0.97000436, -0.24308753, 0.0)
V3 = (-0.93240737, -0.86473146, 0.0)
MASSES = np.full(3, 2.0)  # kg; with G = 0.5, G m = 1: the published orbit (units G = m = 1)
G = 0.5  # not 1 (nor the masses): an engine dropping G or a mass fails
REF_POINTS_PER_PERIOD = 256
REFERENCE_RTOL = 2.5e-14  # DOP853's; atol REFERENCE_RTOL * 1e-3 (positions of order 1 m)
REFERENCE_ERROR = 5e-11  # m: bound on the reference's error over one period (measured 1.2e-11)
RETURN_FLOOR = 1e-7  # m: |x(T) - x(0)| of the converged solution (measured 5.03e-8, times 2)
STEPS_PER_PERIOD = (50, 158, 500)  # the timed dt sweep (a decade), as steps per period
ORDER_STEPS_PER_PERIOD = (1580,)  # untimed, for the order fit: with 158 and 500 a decade
# above the coarsest (T/50, where most methods are unresolved and the fit starts pre-asymptotic)


def initial_state():
    x = np.array([X1, np.negative(X1), (0.0, 0.0, 0.0)])
    v3 = np.array(V3)
    return x, np.array([-0.5 * v3, -0.5 * v3, v3])


# the three pairs (i, j) and the matrix C with a = C @ ((x_j - x_i) / |x_j - x_i|^3) over the
# pairs: a_i = G m_j s_ij for the pairs (i, j), a_j = -G m_i s_ij
PAIRS_I, PAIRS_J = np.array([0, 0, 1]), np.array([1, 2, 2])
PAIR_MATRIX = G * np.array([[MASSES[1], MASSES[2], 0.0], [-MASSES[0], 0.0, MASSES[2]],
                            [0.0, -MASSES[0], -MASSES[1]]])


def accelerations(x):
    """Newtonian accelerations of the three bodies, (..., 9) flat positions -> (..., 9): the
    reference's own formula, written apart from refsim.models.nbody_gravity."""
    x = np.asarray(x, float).reshape(*np.shape(x)[:-1], 3, 3)
    d = x[..., PAIRS_J, :] - x[..., PAIRS_I, :]
    r2 = np.sum(d * d, axis=-1)
    s = d / (r2 * np.sqrt(r2))[..., None]
    return np.matmul(PAIR_MATRIX, s).reshape(*x.shape[:-2], 9)


def _derivative(_, y):
    """d(x, v)/dt of one flat state (18,): `accelerations` for one state, written for the
    per-step cost of solve_ivp's calls (about 20 us; the batched form takes 28)."""
    x = y[:9].reshape(3, 3)
    d = x[PAIRS_J] - x[PAIRS_I]
    r2 = (d * d).sum(axis=1)
    out = np.empty(18)
    out[:9] = y[9:]
    out[9:] = (PAIR_MATRIX @ (d / (r2 * np.sqrt(r2))[:, None])).ravel()
    return out


@lru_cache(maxsize=4)
def reference_grid(periods: float):
    """(t, x, v, a) of the converged solution on REF_POINTS_PER_PERIOD points per period (flat
    states): DOP853's dense output there (see the module docstring)."""
    from scipy.integrate import solve_ivp
    count = int(round(periods * REF_POINTS_PER_PERIOD))
    t = np.linspace(0.0, periods * PERIOD, count + 1)
    x0, v0 = initial_state()
    solved = solve_ivp(_derivative, (0.0, t[-1]), np.concatenate([x0.ravel(), v0.ravel()]),
                       method="DOP853", rtol=REFERENCE_RTOL, atol=REFERENCE_RTOL * 1e-3,
                       t_eval=t)
    if solved.status != 0:
        raise RuntimeError(f"figure_eight reference: {solved.message}")
    x, v = solved.y[:9].T.copy(), solved.y[9:].T.copy()
    return t, x, v, accelerations(x)


def hermite_quintic(t, grid):
    """x, v at times t from the grid's (x, v, a) at the bracketing points (flat states)."""
    tg, xg, vg, ag = grid
    t = np.clip(np.asarray(t, float), tg[0], tg[-1])
    i = np.clip(np.searchsorted(tg, t, side="right") - 1, 0, len(tg) - 2)
    h = (tg[i + 1] - tg[i])[:, None]
    s = ((t - tg[i])[:, None]) / h
    s2, s3, s4, s5 = s * s, s ** 3, s ** 4, s ** 5
    basis = [1 - 10 * s3 + 15 * s4 - 6 * s5, s - 6 * s3 + 8 * s4 - 3 * s5,
             0.5 * (s2 - 3 * s3 + 3 * s4 - s5), 10 * s3 - 15 * s4 + 6 * s5,
             -4 * s3 + 7 * s4 - 3 * s5, 0.5 * (s3 - 2 * s4 + s5)]
    slope = [-30 * s2 + 60 * s3 - 30 * s4, 1 - 18 * s2 + 32 * s3 - 15 * s4,
             s - 4.5 * s2 + 6 * s3 - 2.5 * s4, 30 * s2 - 60 * s3 + 30 * s4,
             -12 * s2 + 28 * s3 - 15 * s4, 1.5 * s2 - 4 * s3 + 2.5 * s4]
    ends = (xg[i], h * vg[i], h * h * ag[i], xg[i + 1], h * vg[i + 1], h * h * ag[i + 1])
    x = sum(b * e for b, e in zip(basis, ends))
    v = sum(b * e for b, e in zip(slope, ends)) / h
    return x, v


def reference_error(periods: float) -> float:
    """Bound on the reference's error over `periods` periods (m): REFERENCE_ERROR max(1, P)^2
    (see the module docstring)."""
    return REFERENCE_ERROR * max(1.0, float(periods)) ** 2


def fastest_rate(periods: float) -> float:
    """Largest local frequency on the orbit (rad/s): sqrt of the spectral radius of da/dx over
    the reference grid (the linearised motion's fastest oscillation)."""
    _, x, _, _ = reference_grid(periods)
    jac = pair_jacobian(x.reshape(len(x), 3, 3), MASSES, G)
    return float(np.sqrt(np.max(np.abs(np.linalg.eigvals(jac)))))


class FigureEight(Case):
    name = "figure_eight"
    description = ("Chenciner-Montgomery figure-eight three-body choreography: converged "
                   "DOP853 reference, return to the start after each period")
    tags = ("particle_fields", "gravity", "orbit", "converged")
    observable, units = "x", "m"
    params = {"periods": Param(1.0, 0.0, 1e3, "run length in periods", low_inclusive=False)}
    variants = {"one_period": {}, "hundred_periods": {"periods": 100.0}}
    quick_variants = ("one_period",)
    default_variants = ("one_period",)
    samples = 128

    def scene(self, p):
        x, v = initial_state()
        return Scene(parts=(Particles(mass=MASSES, position=x, velocity=v),
                            GravityPairs(G=G, softening=0.0)))

    def bodies(self, p):
        return 3

    def t_end(self, p):
        return p["periods"] * PERIOD

    def dts(self, p):
        return [PERIOD / k for k in STEPS_PER_PERIOD]

    def order_dts(self, p):
        return [PERIOD / k for k in ORDER_STEPS_PER_PERIOD]

    def reference_dt(self, p):
        return PERIOD / STEPS_PER_PERIOD[-1]

    def motion_scale(self, p):
        return float(np.linalg.norm(initial_state()[0]))

    def error_floor(self, p):
        return max(reference_error(p["periods"]), self._roundoff(p, min(self.dts(p)))[0])

    def observables(self, p, obs):
        return {"x": np.asarray(obs["x"], float), "v": np.asarray(obs["v"], float)}

    def reference(self, p, t):
        x, v = hermite_quintic(t, reference_grid(p["periods"]))
        return {"x": x.reshape(-1, 3, 3), "v": v.reshape(-1, 3, 3)}

    def energy(self, p, obs):
        return invariants_of(obs, MASSES, G)["energy"]

    def energy_scale(self, p):
        x, v = initial_state()
        return abs(float(invariants_of({"x": x[None], "v": v[None]}, MASSES, G)["energy"][0]))

    def extra_metrics(self, p, obs, observed, reference):
        inv = invariants_of(obs, MASSES, G)
        x, v, t = observed["x"], observed["v"], np.asarray(obs["t"], float)
        periods = t[-1] / PERIOD
        whole = abs(periods - round(periods)) < 1e-9 * max(1.0, periods)
        lever = float(np.sum(np.linalg.norm(x[0], axis=-1) * np.linalg.norm(v[0], axis=-1)))
        drift = np.abs(inv["energy"] - inv["energy"][0])
        half = len(drift) // 2
        return {"return_error": float(np.linalg.norm(x[-1] - x[0])) if whole else np.nan,
                "momentum_drift": vector_drift(inv["momentum"],
                                               float(np.sum(np.linalg.norm(v[0], axis=-1)))),
                "angular_momentum_drift": vector_drift(inv["angular_momentum"], lever),
                "energy_growth": float(np.max(drift[half:]) / max(np.max(drift[:half + 1]),
                                                                  1e-300))}

    def _roundoff(self, p, dt):
        """S = 2 |x0| (positions and velocities of comparable size, rounded once each); the
        phase error a rounding starts grows as 1 + 1.5 n t (n = 2 pi / T; T ~ |E|^-1.5 for a potential
        homogeneous of degree -1, as for Kepler)."""
        steps = int(round(self.t_end(p) / dt))
        bound, reason = roundoff_tolerance(steps, 2.0 * self.motion_scale(p))
        growth = 1.0 + 1.5 * 2.0 * np.pi / PERIOD * self.t_end(p)
        return bound * growth, f"{reason}, times 1 + 1.5 n t = {growth:.3g} (n = 2 pi / T)"

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        t_end = self.t_end(p)
        roundoff, roundoff_reason = self._roundoff(p, dt)
        reference = reference_error(p["periods"])
        floor = f"; plus the reference's own error {reference:.3g} m"
        grid = reference_grid(p["periods"])
        tol, reason = orbit_bound(
            integrator, GravitySystem(MASSES, G), lambda t: hermite_quintic(t, grid),
            lambda x: pair_jacobian(x.reshape(len(x), 3, 3), MASSES, G), dt,
            sampled_steps(t_end, self.sample_dt(p), dt))
        return tol + roundoff + reference, reason + roundoff_reason + floor


CASE = FigureEight()
