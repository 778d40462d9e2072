"""Boids: N birds under Cucker-Smale alignment (default) or Reynolds' three rules (by name).

Scene: N particles of mass `mass` (unused by the rules, which are accelerations: a mass
other than 1 shows an engine dividing them by it) in a cube of side `box` (uniform, seeded),
velocities mean (speed, 0, 0) plus `spread` x standard normal components;
`Scene(parts=(Particles(...), Flocking(...)))`. Compared observable `x` (m): the
positions against a converged reference, scipy's DOP853 (`solve_ivp`, rtol = atol = 1e-12) on the same accelerations
(refsim/models/flocking.py); error = the l2 norm over all birds at each sample.

Cucker-Smale (Cucker & Smale 2007, IEEE TAC 52(5)): the mean velocity is conserved to
round-off by every stepper (proof in refsim/models/flocking.py: the pair term is antisymmetric),
column `mean_velocity_drift` (m/s); the velocity variance decays (flocking), a measured curve
(series `velocity_variance`, figure over the Ha & Liu 2009 bound var(0) exp(-2 psi(D_inf) t),
valid for beta <= 1/2: unconditional flocking), columns `variance_ratio` = var(T)/var(0) and
`variance_bound_ratio` = max_{t > 0} var(t) / bound(t) (<= 1 for the flow, up to the run's error).
Reynolds (variant "reynolds", Reynolds 1987; slide 000 names the rules and prints no formula:
the form used is refsim/scene/flocking.py's): no conservation, `mean_velocity_drift` shows it;
its hard neighbourhood radius makes the acceleration jump when a bird crosses it, so every
stepper is first order there.

Tolerance (Cucker-Smale, every fixed-step method): the exact discrete solution of the named
method on the flow linearised at the start (psi_ij frozen: x'' = -L v, L the alignment
Laplacian; `frozen_error`, mode by mode from refsim.expected's step matrices) against that
linear flow's exact solution, times one safety factor 2 for psi_ij's change along the run
(measured: the real error is 0.93 .. 1.07 of the frozen model's on the default sweep), plus
the reference's own error (sqrt(N) REFERENCE_ERROR) and round-off. Reynolds and dopri5_adaptive keep
the generic order bound (`order_tolerance`): Reynolds' rules jump, no linear model holds.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from refsim.case import Case, Param, order_tolerance, roundoff_tolerance
from refsim.expected import has_discrete_solution, maps
from refsim.models.flocking import (FlockSystem, diameter_bound, velocity_variance,
                                    variance_bound)
from refsim.scene import Particles, Scene
from refsim.scene.flocking import RULES, Flocking

SAFETY = 2.0  # the one safety factor of the Cucker-Smale bound (tolerance)
# m per bird: DOP853 at rtol 1e-12 against rtol 1e-14 errs by 1.28e-11 m in the l2 norm over
# N = 24 birds (2.6e-12 per bird); the reference's error in the l2 norm is sqrt(N) times this
REFERENCE_ERROR = 6e-12


class Boids(Case):
    name = "boids"
    description = ("flocking birds: Cucker-Smale keeps the mean velocity to round-off while "
                   "the velocity variance decays; Reynolds' rules (by name) do not keep it")
    tags = ("particle_fields", "flocking", "all_pairs")
    observable, units = "x", "m"
    params = {
        "rule": Param("cucker_smale", choices=RULES, doc="flocking rule"),
        "n": Param(24, 2, 5000, "birds"),
        "K": Param(1.5, 0.0, 1e3, "Cucker-Smale strength (1/s)", low_inclusive=False),
        "sigma": Param(0.7, 0.0, 1e3, "Cucker-Smale length (m)", low_inclusive=False),
        "mass": Param(0.25, 0.0, 1e3, "each bird's mass (kg): the rules are accelerations, "
                      "so an engine that divides them by the mass fails", low_inclusive=False),
        "beta": Param(0.25, 0.0, 10.0, "Cucker-Smale decay exponent"),
        "radius": Param(1.0, 0.0, 1e3, "Reynolds neighbourhood (m)", low_inclusive=False),
        "separation": Param(0.05, 0.0, 1e3, "Reynolds separation weight (m^2/s^2)"),
        "alignment": Param(1.0, 0.0, 1e3, "Reynolds alignment weight (1/s)"),
        "cohesion": Param(0.5, 0.0, 1e3, "Reynolds cohesion weight (1/s^2)"),
        "box": Param(2.0, 0.0, 1e3, "side of the starting cube (m)", low_inclusive=False),
        "speed": Param(1.0, -1e3, 1e3, "mean starting speed along x (m/s)"),
        "spread": Param(0.5, 0.0, 1e3, "velocity spread (m/s)", low_inclusive=False),
        "seed": Param(1, 0, 2 ** 31, "starting state"),
        "duration": Param(2.0, 0.0, 1e3, "s", low_inclusive=False),
    }
    variants = {"cucker_smale": {}, "large": {"n": 1000}, "long": {"duration": 8.0},
                "reynolds": {"rule": "reynolds"}}
    quick_variants = ("cucker_smale",)
    default_variants = ("cucker_smale",)
    order_meaningful = True
    samples = 50  # observations per run: the variance curve needs no more

    def initial_state(self, p):
        rng = np.random.default_rng(int(p["seed"]))
        n = int(p["n"])
        x = (rng.random((n, 3)) - 0.5) * p["box"]
        v = np.array([p["speed"], 0.0, 0.0]) + p["spread"] * rng.standard_normal((n, 3))
        return x, v

    def flocking(self, p):
        return Flocking(rule=p["rule"], K=p["K"], sigma=p["sigma"], beta=p["beta"],
                        radius=p["radius"], separation=p["separation"],
                        alignment=p["alignment"], cohesion=p["cohesion"])

    def scene(self, p):
        x, v = self.initial_state(p)
        return Scene(parts=(Particles(mass=np.full(len(x), p["mass"]), position=x,
                                      velocity=v),
                            self.flocking(p)))

    def t_end(self, p):
        return p["duration"]

    def dts(self, p):
        return [4e-2, 2e-2]

    def order_dts(self, p):
        """Accuracy-only steps, so that the order fit spans a decade of dt (0.08 .. 0.008)."""
        return [8e-2, 8e-3]

    def reference_dt(self, p):
        return 2e-2

    def bodies(self, p):
        return int(p["n"]) ** 2  # all pairs: the work grows as N^2

    def rate(self, p):
        """omega (1/s): the Gershgorin bound of the velocity Jacobian, 2 max psi = 2 K /
        sigma^(2 beta) (Cucker-Smale); w_a + sqrt(w_c) + sqrt(w_s) / radius (Reynolds)."""
        if p["rule"] == "cucker_smale":
            return 2.0 * p["K"] / p["sigma"] ** (2 * p["beta"])
        return p["alignment"] + np.sqrt(p["cohesion"]) + np.sqrt(p["separation"]) / p["radius"]

    def motion_scale(self, p):
        """max_i |v_i - mean v| T (m): the birds' motion relative to the flock (the mean
        motion is exact: a linear invariant)."""
        x, v = self.initial_state(p)
        return float(np.max(np.linalg.norm(v - v.mean(axis=0), axis=1))) * p["duration"]

    def observables(self, p, obs):
        v = np.asarray(obs["v"], float)
        mean = v.mean(axis=1)
        return {"x": np.asarray(obs["x"], float), "velocity_variance": velocity_variance(v),
                "mean_velocity_drift": np.linalg.norm(mean - mean[0], axis=1)}

    def reference(self, p, t):
        dense = _reference_solution(tuple(sorted(p.items())))
        y = dense(np.asarray(t, float)).T
        n3 = 3 * int(p["n"])
        x, v = y[:, :n3].reshape(len(y), -1, 3), y[:, n3:].reshape(len(y), -1, 3)
        return {"x": x, "velocity_variance": velocity_variance(v),
                "mean_velocity_drift": np.zeros(len(x))}

    def variance_bound(self, p, t):
        """Ha & Liu's bound on the velocity variance (inf where it does not apply)."""
        if p["rule"] != "cucker_smale":
            return np.full(len(np.asarray(t)), np.inf)
        var0, rate = _flocking_rate(tuple(sorted(p.items())))
        return var0 * np.exp(-2.0 * rate * np.asarray(t, float))

    def extra_metrics(self, p, obs, observed, reference):
        var = observed["velocity_variance"]
        bound = self.variance_bound(p, np.asarray(obs["t"], float))
        return {"mean_velocity_drift": float(np.max(observed["mean_velocity_drift"])),
                "variance_ratio": float(var[-1] / var[0]),
                "variance_bound_ratio": float(np.max(var[1:] / bound[1:]))}

    def figures(self, p):
        t = np.linspace(0.0, p["duration"], 41)
        bound = self.variance_bound(p, t)
        if not np.all(np.isfinite(bound)):
            return []
        x, v = self.initial_state(p)
        d_inf = diameter_bound(x, v, p["K"], p["sigma"], p["beta"])
        return [{"kind": "trace_over_data", "title": "flocking: velocity variance",
                 "x": "t", "y": "velocity_variance", "x_shift_column": None,
                 "x_label": "t (s)", "y_label": "(1/N) sum |v_i - mean v|^2 (m^2/s^2)",
                 "data": {"x": t.tolist(), "y": bound.tolist(),
                          "label": f"Ha & Liu (2009) bound, D_inf = {d_inf:.3g} m"}}]

    def roundoff(self, p, dt):
        x, v = self.initial_state(p)
        state_scale = float(np.max(np.abs(x)) + np.max(np.abs(v)) * p["duration"])
        return roundoff_tolerance(int(round(p["duration"] / dt)), np.sqrt(len(x)) * state_scale)

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        roundoff, roundoff_reason = self.roundoff(p, dt)
        reference = REFERENCE_ERROR * np.sqrt(p["n"])
        floor = (f"; plus the reference's own error sqrt(N) x {REFERENCE_ERROR:g} = "
                 f"{reference:.3g} m")
        if p["rule"] == "cucker_smale" and has_discrete_solution(integrator):
            frozen = frozen_error(p, integrator, dt)
            return SAFETY * frozen + reference + roundoff, (
                f"{SAFETY:g} x {frozen:.4g} m: the exact discrete solution of {integrator} on "
                "the flow linearised at the start (psi_ij frozen at t = 0: x'' = -L v, L the "
                "alignment Laplacian, solved mode by mode, refsim.expected) against that "
                f"flow's exact solution, max over the samples; safety factor {SAFETY:g} for "
                "psi_ij's change along the run (the birds drift apart), which the frozen model "
                "leaves out (measured 0.93..1.07 of the real error on the default sweep)"
                + floor + roundoff_reason)
        omega_t, y = self.rate(p) * p["duration"], self.rate(p) * dt
        order = min(order, 1) if p["rule"] == "reynolds" else order
        tol = order_tolerance(self.motion_scale(p), omega_t, y, order, symplectic=False)
        reason = (f"order {order:g}: motion x expm1(omega T (omega dt)^p) (order_tolerance, "
                  f"not symplectic: the rule is dissipative), omega = {self.rate(p):.3g} 1/s "
                  "the Gershgorin bound of the velocity Jacobian; motion = max |v_i - mean v| T"
                  + ("; Reynolds: first order at best, the acceleration jumps where a bird "
                     "crosses the neighbourhood radius" if p["rule"] == "reynolds" else ""))
        return tol + roundoff + reference, reason + floor + roundoff_reason


def alignment_laplacian(p, x) -> np.ndarray:
    """B = -L (n, n): a_i = (1/N) sum_j psi_ij (v_j - v_i) = (B v)_i at positions x."""
    d = x[None, :, :] - x[:, None, :]
    psi = p["K"] * (p["sigma"] ** 2 + np.einsum("ijk,ijk->ij", d, d)) ** -p["beta"]
    return (psi - np.diag(psi.sum(axis=1))) / len(x)


def frozen_error(p, integrator, dt) -> float:
    """max over the sampled steps of the l2 position error over all birds of the named
    method's exact discrete solution on x'' = B v, B = -L(x0) frozen at the start, against
    that linear flow's exact solution. B is symmetric: in its eigenbasis (orthogonal, so the l2
    norm is unchanged) each mode mu <= 0 is a scalar x'' = mu v; a start x0 stays put exactly
    (A = 0), and a unit v0 moves x by g(t) = (e^(mu t) - 1) / mu (t at mu = 0) in the flow and by
    O S^k T (0, 1) in the method (`refsim.expected.maps`): error_k^2 = sum over modes of
    (g_k - g(t_k))^2 |v0 modal|^2."""
    x0, v0 = CASE.initial_state(p)
    mu, basis = np.linalg.eigh(alignment_laplacian(p, x0))
    speed2 = np.sum((basis.T @ v0) ** 2, axis=1)
    steps = int(round(CASE.t_end(p) / dt))
    stride = max(1, int(round(CASE.sample_dt(p) / dt)))
    ks = np.unique(np.append(np.arange(0, steps + 1, stride), steps))
    t = ks * dt
    mapped = [maps(integrator, 0.0, rate, dt) for rate in mu]  # (T, S, O) per mode
    step = np.array([m[1] for m in mapped])
    z = np.array([m[0] @ np.array([0.0, 1.0]) for m in mapped])[..., None]
    out = np.array([m[2][0] for m in mapped])  # the x row of O
    done, disc = 0, np.empty((len(mu), len(ks)))
    for i, k in enumerate(ks):  # stacked powers, every mode at once
        z = np.linalg.matrix_power(step, int(k) - done) @ z
        done, disc[:, i] = int(k), np.einsum("mj,mj->m", out, z[..., 0])
    small = np.abs(mu * t[-1]) < 1e-12
    flow = np.where(small[:, None], t,
                    np.expm1(np.outer(mu, t)) / np.where(small, 1.0, mu)[:, None])
    gap = disc - flow
    return float(np.sqrt(np.max(speed2 @ gap ** 2)))


@lru_cache(maxsize=8)
def _flocking_rate(key):
    """(var(0), psi(D_inf)): Ha & Liu's bound var(0) exp(-2 psi(D_inf) t), once per set."""
    p = dict(key)
    x, v = CASE.initial_state(p)
    var0 = float(variance_bound(x, v, 0.0, p["K"], p["sigma"], p["beta"]))
    d_inf = diameter_bound(x, v, p["K"], p["sigma"], p["beta"])
    return var0, p["K"] * (p["sigma"] ** 2 + d_inf ** 2) ** -p["beta"]


@lru_cache(maxsize=8)
def _reference_solution(key):
    """The dense DOP853 solution (rtol = atol = 1e-12, its 7th-order interpolant between
    steps) of the case's model: a callable t -> (6n, T) state [x, v] (one solve per
    parameter set, shared by every dt)."""
    from scipy.integrate import solve_ivp
    p = dict(key)
    x0, v0 = CASE.initial_state(p)
    system, n3 = FlockSystem(CASE.flocking(p), len(x0)), x0.size

    def rhs(t, y):
        return np.concatenate([y[n3:], system.accel(t, y[:n3], y[n3:])])

    sol = solve_ivp(rhs, (0.0, CASE.t_end(p)), np.concatenate([x0.ravel(), v0.ravel()]),
                    method="DOP853", dense_output=True, rtol=1e-12, atol=1e-12)
    return sol.sol


CASE = Boids()
