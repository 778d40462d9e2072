"""Pendulum: a point mass on a rigid massless rod of length L, released from rest at theta0.

Exact solution (docs/engine_notes.md#exact-pendulum-solution-and-period; e.g. Lawden, Elliptic
Functions and Applications, ch. 5): with m = sin^2(theta0/2) and w0 = sqrt(g/L),
  theta(t)  = 2 arcsin( sqrt(m) sn(K(m) - w0 t | m) ),
  theta'(t) = -2 sqrt(m) w0 cn(K(m) - w0 t | m),
period 4 K(m) / w0. scipy's `ellipj`/`ellipk` take the parameter m = k^2; the argument is reduced
modulo the period 4K before evaluation so that long runs keep full accuracy.
Observables `theta` (rad, compared) and `theta_dot` (rad/s); `constraint_drift` is the largest
rod-length error |r| - L (m) where the engine uses maximal coordinates. The pivot is the origin,
the hinge axis y, gravity -z: the motion stays in the x-z plane. The bob's mass is 0.5 kg (not
1, so that an engine forgetting to divide by it in its constraint solve fails).
Expected errors (`tolerance`): the named method on the unit linear oscillator at the swing's
fastest rate (refsim.expected: its exact discrete solution and oscillator rates), converted to
theta by the swing's sensitivities (a time shift, the elliptic period's change with the
energy, the amplitude), times one safety factor.
"""
from __future__ import annotations

import numpy as np
from scipy.special import ellipe, ellipj, ellipk

from refsim.case import Case, Param, adaptive_rtol, roundoff_tolerance, sample_steps
from refsim.expected import discrete_solution, oscillator_rates
from refsim.integrators import get_integrator
from refsim.scene import Body, Joint, Joints, Particles, Scene

from .stiff_spring import adaptive_bound

# The one safety factor: the unit linear oscillator's errors (at the fastest rate, converted
# by the swing's sensitivities) are the leading terms only; the nonlinear swing's harmonics
# and the cross terms are left out. Measured over the default matrix, the bound without it is
# at least 1.0x the error (symplectic Euler's first-order shape error: 1.003x).
SAFETY = 2.0


def exact_pendulum(theta0, w0, t):
    """(theta, theta') of the undamped pendulum released from rest at theta0."""
    m = np.sin(0.5 * theta0) ** 2
    quarter = ellipk(m)
    u = np.mod(quarter - w0 * np.asarray(t, float), 4.0 * quarter)
    sn, cn, _, _ = ellipj(u, m)
    k = np.sqrt(m)
    return 2.0 * np.arcsin(k * sn), -2.0 * k * w0 * cn


def period(theta0, w0):
    return 4.0 * ellipk(np.sin(0.5 * theta0) ** 2) / w0


class Pendulum(Case):
    name = "pendulum"
    description = "point mass on a rigid rod released from rest at theta0; Jacobi-elliptic exact"
    tags = ("rigid", "constraint", "joints", "exact")
    observable, units = "theta", "rad"
    params = {
        "theta0": Param(1.0, 0.0, np.pi, "release angle (rad)", low_inclusive=False),
        "length": Param(1.0, 0.0, 1e3, "rod length L (m)", low_inclusive=False),
        "mass": Param(0.5, 0.0, 1e6, "kg", low_inclusive=False),
        "g": Param(9.81, 0.0, 1e3, "m/s^2", low_inclusive=False),
        "duration": Param(10.0, 0.0, 1e4, "s", low_inclusive=False),
    }
    variants = {"default": {}, "large_amplitude": {"theta0": 3.0}}
    # the maximal-coordinate formulations (kkt, penalty: 47 s of the default run's work per
    # variant) are compared on the default swing; the large one sweeps the generalized
    # coordinate (name the variant, or --full, for its kkt and penalty rows)
    alternatives_variants = ("default",)

    @staticmethod
    def omega(p):
        return np.sqrt(p["g"] / p["length"])

    def scene(self, p):
        L, th = p["length"], p["theta0"]
        bob = Body(mass=p["mass"], position=(L * np.sin(th), 0.0, -L * np.cos(th)), name="bob")
        rod = Joint(body=0, anchor=(0.0, 0.0, 0.0), length=L, axis=(0.0, 1.0, 0.0))
        return Scene(parts=(Particles.of((bob,)), Joints.of((rod,))),
                     gravity=(0.0, 0.0, -p["g"]), planar=True)

    def t_end(self, p):
        return p["duration"]

    def dts(self, p):
        return [4e-3, 2e-3, 1e-3]

    def order_dts(self, p):
        """Coarser steps run for the convergence order only (accuracy pass, no timing): with
        the timed 4..1 ms they span 50..1 ms (w0 dt <= 0.16), a decade for every order 1..5
        whose errors stay on one slope above the error floor."""
        return [5e-2, 1.25e-2]

    def error_floor(self, p):
        """Round-off, growing with the run's length: the engines' after the 1e4 steps of 10 s
        at 1 ms (MuJoCo's RK4 errs 2.9e-11 where refsim's truncation is 1.5e-11) and the
        reference's (scipy's ellipj near m = 1: 2e-11 over 10 s at theta0 = 3), both
        <= 3e-12 theta0 per second: taken 1e-11 theta0 per second of the run."""
        return 1e-11 * p["theta0"] * p["duration"]

    def reference_dt(self, p):
        return 1e-3

    def observables(self, p, obs):
        x, v = obs["x"][:, 0, :], obs["v"][:, 0, :]
        r2 = x[:, 0] ** 2 + x[:, 2] ** 2
        out = {"theta": np.arctan2(x[:, 0], -x[:, 2]),
               "theta_dot": (x[:, 0] * v[:, 2] - x[:, 2] * v[:, 0]) / r2}
        if "constraint" in obs:
            out["constraint"] = obs["constraint"][:, 0]
        return out

    def reference(self, p, t):
        theta, theta_dot = exact_pendulum(p["theta0"], self.omega(p), t)
        return {"theta": theta, "theta_dot": theta_dot}

    def energy(self, p, obs):
        x, v = obs["x"][:, 0, :], obs["v"][:, 0, :]
        return p["mass"] * (0.5 * np.sum(v * v, axis=-1) + p["g"] * x[:, 2])

    def energy_period(self, p, settings=None):
        """In generalized coordinates (theta, separable H = p^2/(2 m L^2) - m g L cos theta)
        the swing's period 4 K(m) / w0; in maximal coordinates the rod's constraint brings
        its own dynamics (Baumgarte, a penalty spring): no energy behaviour claimed."""
        from refsim.stress.spec import declared_formulations
        forms = declared_formulations(settings or {})
        if not (forms and all("generalized coordinate" in form for form in forms)):
            return None
        return 4.0 * ellipk(np.sin(0.5 * p["theta0"]) ** 2) / self.omega(p)

    def energy_scale(self, p):
        return p["mass"] * p["g"] * p["length"]

    def motion_scale(self, p):
        return p["theta0"]

    def sensitivities(self, p):
        """theta's error per unit error of a unit-amplitude linear oscillator at w0 (the
        swing's fastest rate: sqrt|d(theta'')/d theta| = w0 sqrt|cos theta| <= w0), whose
        phase error Phi is a time shift Phi / w0: S_t = max|theta'| / w0 = 2 sin(theta0 / 2);
        per unit ln(amplitude) error (the energy changes by 2 ln), S_a = 2 d theta0 / d ln E =
        2 tan(theta0 / 2) (E = m g L (1 - cos theta0)); kappa = dlnT/dlnE, the period's
        change with the energy."""
        theta0 = p["theta0"]
        return (2.0 * np.sin(0.5 * theta0), 2.0 * np.tan(0.5 * theta0),
                period_sensitivity(theta0))

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        """The named method on the unit linear oscillator at the fastest rate w of the system
        integrated (`_fastest_rate`: w0, or the KKT formulation's Baumgarte rate), from
        refsim.expected (`_linear_errors`): its phase error Phi and ln amplitude a over the
        run's n steps and its bounded shape error s. theta errs
            S_t ((w0 / w) Phi + s + kappa a w0 t) + (S_a - S_t) a
        (`sensitivities`: a phase error at w is a time shift Phi / w, theta' at most S_t w0;
        an energy error 2a grows linearly and the elliptic period follows it by kappa; the
        swing's size follows the energy by S_a / 2), times the one safety factor SAFETY, plus
        the formulation's term and round-off. dopri5_adaptive: Phi = a = Dormand-Prince's
        error at its controller's step limit on that oscillator of amplitude theta0
        (stiff_spring.adaptive_bound) / theta0, s = 0."""
        theta0, t, w0 = p["theta0"], p["duration"], self.omega(p)
        s_time, s_amp, kappa = self.sensitivities(p)
        rate, rate_reason = self._fastest_rate(p, settings)
        extra, extra_reason = self._formulation_error(p, engine_variant, settings)
        roundoff, roundoff_reason = self._roundoff(p, dt)
        if adaptive_rtol(integrator) is not None:
            deviation, why = self._adaptive(p, integrator, dt, rate)
            big_phi = amp = deviation / theta0
            shape = 0.0
        else:
            big_phi, amp, shape, why = self._linear_errors(p, integrator, dt, rate)
            why += f" ({rate_reason})"
            if rate > w0 and get_integrator(integrator).symplectic:
                # Baumgarte's term is dissipative: on the KKT system the named symplectic
                # method is not symplectic (the engine declares so), and its local error per
                # step, the phase error at w, is an energy error too, which accumulates
                amp = big_phi + shape
                why += ("; not symplectic on the KKT system: a = Phi + s, its local errors "
                        "taken as energy errors")
        direct = s_time * (w0 / rate * big_phi + shape)
        tol = SAFETY * (direct + s_time * kappa * amp * w0 * t + (s_amp - s_time) * amp)
        return tol + extra + roundoff, (
            f"{why}; theta errs S_t ((w0 / w) Phi + s + kappa a w0 t) + (S_a - S_t) a, S_t = "
            f"{s_time:.3g}, kappa = {kappa:.3g}, S_a = {s_amp:.3g} (see sensitivities), times "
            f"the safety factor {SAFETY:g}" + extra_reason + roundoff_reason)

    def _linear_errors(self, p, integrator, dt, rate):
        """The named method on the unit linear oscillator x'' = -w^2 x at w = rate
        (refsim.expected): its per-step phase error and ln|lambda| over the run's n steps,
        Phi = n |phase| and a = n |ln|lambda||, and its shape error s: its exact discrete
        solution's largest distance, over the samples, from |lambda|^k cos(k arg lambda) (the
        O((w dt)^p) difference of its eigenvectors from the exact ones: bounded, a first-order
        method's leading error)."""
        steps = int(round(p["duration"] / dt))
        phase, log_amp = oscillator_rates(integrator, rate * dt)
        if not np.isfinite(phase):
            return np.inf, np.inf, np.inf, (f"{integrator} at w dt = {rate * dt:.3g} is past "
                                            "its oscillatory range")
        k = sample_steps(steps, int(round(self.sample_dt(p) / dt)))
        x, _ = discrete_solution(integrator, -rate * rate, 0.0, 1.0, 0.0, dt, k)
        shape = float(np.max(np.abs(x[:, 0] - np.exp(k * log_amp)
                                    * np.cos(k * (rate * dt + phase)))))
        big_phi, amp = steps * abs(phase), steps * abs(log_amp)
        return big_phi, amp, shape, (
            f"{integrator} on the unit linear oscillator at w = {rate:.4g} rad/s (w dt = "
            f"{rate * dt:.3g}; refsim.expected): over {steps} steps phase Phi = {big_phi:.3g} "
            f"rad, ln amplitude a = {amp:.3g}, shape error s = {shape:.3g}")

    def _fastest_rate(self, p, settings):
        """The fastest rate of the system the engine integrates: the swing's, w0 (sqrt|d
        theta''/d theta| = w0 sqrt|cos theta| <= w0), or in maximal coordinates with
        Baumgarte stabilisation its rate (settings baumgarte_w), where larger: an order-p
        method's error per unit time grows like (w h)^p w with it."""
        w0, fast = self.omega(p), float((settings or {}).get("baumgarte_w", 0.0))
        if fast > w0:
            return fast, "the Baumgarte rate of the KKT formulation, the fastest"
        return w0, "the swing's fastest rate"

    def _adaptive(self, p, integrator, dt, w, samples=4000):
        """dopri5_adaptive on the linear oscillator theta'' = -w^2 theta of amplitude theta0
        (one generalized coordinate)."""
        theta0 = p["theta0"]

        def states(t):
            return np.column_stack([theta0 * np.cos(w * t), -theta0 * w * np.sin(w * t)])

        t = np.linspace(0.0, p["duration"], samples)
        return adaptive_bound(integrator, [[-w * w]], [[0.0]], t, states(t), states, dt,
                              lambda e: np.abs(e[:, 0]), 0.0, components=1)

    def _roundoff(self, p, dt):
        """Rounding the state once errs in theta by at most eps theta0 for a hinge angle
        (theta and theta'/w0 are both <= theta0) and eps (1 + theta0) / sqrt(2) for Cartesian
        coordinates (x and v to eps/2 of L and of L theta' per component): S = 1 + theta0
        covers both. A rounding changes the energy, hence the period (kappa = dlnT/dlnE),
        and the phase error it starts grows over the rest of the run: times 1 + kappa w0 t."""
        growth = 1.0 + period_sensitivity(p["theta0"]) * self.omega(p) * p["duration"]
        bound, reason = roundoff_tolerance(int(round(p["duration"] / dt)),
                                           1.0 + p["theta0"])
        return bound * growth, f"{reason}, times 1 + kappa w0 t = {growth:.3g}"

    @staticmethod
    def _formulation_error(p, engine_variant, settings):
        inertia = (settings or {}).get("point_inertia")  # kg m^2 an engine gives the bob
        if inertia:
            share = inertia / (p["mass"] * p["length"] ** 2)
            w_t = np.sqrt(p["g"] / p["length"]) * p["duration"]
            return p["theta0"] * w_t * share / 2, (
                f"; plus the bob's own inertia I = {inertia:g} kg m^2: (m L^2 + I) theta'' "
                f"slows w0 by I / (2 m L^2) = {share / 2:.2g}, a phase error theta0 w0 t "
                "I / (2 m L^2) (dt-independent)")
        ratio = (settings or {}).get("penalty_ratio")
        if ratio:
            stretch = 1.0 + 2.0 * (1.0 - np.cos(p["theta0"]))
            w_t = np.sqrt(p["g"] / p["length"]) * p["duration"]
            return p["theta0"] * w_t * stretch / ratio ** 2, (
                f"; plus the penalty rod's stretch (w0/w_rod)^2 (1 + 2(1 - cos theta0)) L = "
                f"{stretch / ratio ** 2:.2g} L, which slows the swing by half that fraction, "
                "accumulated over w0 t (bound taken without the half)")
        if engine_variant == "kkt":
            return 0.0, ("; Baumgarte at a fixed rate (w = 5 w0) keeps the rod length to the "
                         "integrator's error and the method's order")
        return 0.0, ""

    def stability(self, p):
        """`refsim stress`: y = omega0 dt on the small-amplitude pendulum (theta0 = 1e-3 rad,
        sin theta = theta to 2e-7), stable while the oscillation energy E + m g L stays below
        F times its initial m g L (1 - cos theta0). In generalized coordinates the motion is
        theta'' = -omega0^2 theta, so the theory is the spring's per stepper; in maximal
        coordinates the rod's constraint (multipliers with Baumgarte, a penalty spring,
        impulses) brings its own dynamics and no theory is stated. Every engine formulation
        is searched."""
        from refsim.stress.spec import oscillator_spec
        swing = 2.0 * p["mass"] * p["g"] * p["length"] * np.sin(0.5 * p["theta0"]) ** 2
        return oscillator_spec(self.omega(p), -p["mass"] * p["g"] * p["length"], swing,
                               "small-amplitude pendulum: theta'' = -omega0^2 theta in "
                               "generalized coordinates, the linear oscillator's stability",
                               {"theta0": 1e-3}, theory=pendulum_stability_theory,
                               formulations=True)


def pendulum_stability_theory(stepper, settings):
    """The spring's limit where every formulation the Sim declares is in generalized
    coordinates; NaN (with the reason) otherwise."""
    from refsim.stress.spec import declared_formulations, stepper_theory
    forms = declared_formulations(settings)
    if forms and all("generalized coordinate" in form for form in forms):
        limit, why = stepper_theory(stepper)
        return limit, why + "; generalized coordinates: theta'' = -omega0^2 theta"
    return np.nan, ("no theory: the formulation is not declared in generalized coordinates "
                    f"({'; '.join(forms) or 'none declared'}): the rod's constraint adds its "
                    "own dynamics")


def period_sensitivity(theta0):
    """kappa = dlnT/dlnE at release angle theta0: with m = sin^2(theta0/2) = E/(2 m g L),
    T = 4 K(m)/w0 and dK/dm = (E(m) - (1 - m) K(m)) / (2 m (1 - m))."""
    m = np.sin(0.5 * theta0) ** 2
    k = ellipk(m)
    return (ellipe(m) - (1.0 - m) * k) / (2.0 * (1.0 - m) * k)


CASE = Pendulum()
