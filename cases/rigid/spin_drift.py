"""Spin drift: a free body spinning at constant rate about a principal axis tilted in the world.

The body (principal moments diag(1, 2, 3) kg m^2) spins at |w| about its body axis 3, which is
tilted by `tilt` degrees from world z (and twisted 0.4 rad about itself, so no body axis lies
on a world axis). Then I w is parallel to w, w x (I w) = 0: w stays constant exactly and the
orientation is q(t) = exp(t w / 2) (x) q0 (a rotation by angle |w| t about w). Compared
observable `angle_error`: the angle (rad) of the rotation between the observed and the exact
orientation; `w_error` = |w(t) - w0| (rad/s) should stay at round-off.
Exact discrete oracles (docs/models.md#rigid-orientation-defect-per-step), at constant w and
y = h |w|, per step of a one-stage (semi-implicit Euler) orientation update:
- matrix as printed, R_{k+1} = (I + h [w]_x) R_k: det R_k = (1 + y^2)^k (I + h [w]_x is
  sqrt(1 + y^2) times a rotation by atan(y) in the plane normal to w, 1 along w);
- quaternion Euler step, q + (h/2) (0, w) (x) q = (1, (h/2) w) (x) q: |q|^2 grows by
  1 + y^2/4 a step before normalising (the defect the engine reports is that product - 1);
- exponential map and polar factor: no defect.
The rotation each step makes is y (exp map), 2 atan(y/2) (normalised quaternion step),
atan(y) (polar factor, and the polar factor of the printed matrix): `discrete_angle_error`.
"""
from __future__ import annotations

import numpy as np

from refsim.case import EPS, Param, adaptive_rtol, roundoff_tolerance
from refsim.expected import oscillator_rates
from refsim.scene import RigidBodies, Scene

from . import RigidCase, quat_multiply, rotation_angle_between, rotation_quaternion
from ._bounds import (KICK_METHODS, chart_step_angle, gyroscopic_rate, kick_amplitude_rate,
                      method_name)

FORMULATIONS = ("matrix_printed", "matrix_polar", "quat_normalised", "quat_exp")
PRINCIPAL_MOMENTS = (1.0, 2.0, 3.0)  # kg m^2; the spin is about the third (largest) axis
TWIST = 0.4  # rad about body axis 3 before the tilt
DRIFT_VELOCITY = (0.05, 0.0, -0.1)  # m/s, the centre of mass's free flight


def _step_angle(formulation: str, y):
    if formulation not in FORMULATIONS:
        raise ValueError(f"formulation must be one of {list(FORMULATIONS)}, got "
                         f"{formulation!r}")
    return {"quat_exp": y, "quat_normalised": 2.0 * np.arctan(0.5 * y),
            "matrix_polar": np.arctan(y), "matrix_printed": np.arctan(y)}[formulation]


def _step_rotation(h, w):
    """y = h |w| for a scalar rate |w| or a (..., 3) angular velocity."""
    w = np.asarray(w, float)
    rate = np.linalg.norm(w, axis=-1) if w.ndim and w.shape[-1] == 3 else np.abs(w)
    return np.asarray(h, float) * rate


def discrete_defect(formulation: str, h, w, k):
    """Exact orientation defect after k steps of h at constant w (a vector (..., 3) or its
    norm): (1 + h^2 |w|^2)^k - 1 = det R_k - 1 for the printed matrix step, (1 + h^2 |w|^2
    / 4)^k - 1 for the Euler quaternion step (the squared norm renormalisation removed, over
    all k steps), 0 for the exponential map and the polar factor."""
    y = _step_rotation(h, w)
    _step_angle(formulation, y)  # validates the name
    k = np.asarray(k, float)
    if formulation == "matrix_printed":
        return np.expm1(k * np.log1p(y * y))
    if formulation == "quat_normalised":
        return np.expm1(k * np.log1p(0.25 * y * y))
    return np.zeros(np.broadcast(y, k).shape)


def discrete_angle_error(formulation: str, h, w, k):
    """Exact rotation-angle error (rad, unwrapped: it may exceed pi) after k steps of h at
    constant w: k (h |w| - step angle), the step angle being h |w| (exp map), 2 atan(h |w|/2)
    (normalised quaternion step), atan(h |w|) (polar factor; the printed matrix's polar
    factor too: the powers of I + h [w]_x commute with R0's rotation about w)."""
    y = _step_rotation(h, w)
    return np.asarray(k, float) * (y - _step_angle(formulation, y))


class SpinDrift(RigidCase):
    name = "spin_drift"
    description = ("constant spin about a tilted principal axis: exact orientation "
                   "exp(t w/2) q0 and the exact discrete drift of det R / |q| per formulation")
    tags = ("rigid", "rotation", "exact")
    observable, units = "angle_error", "rad"
    params = {
        "spin": Param(1.0, 0.0, 1e4, "|w| (rad/s) about body axis 3", low_inclusive=False),
        "tilt": Param(30.0, 0.0, 180.0, "angle of body axis 3 from world z (deg)"),
        "mass": Param(1.0, 0.0, 1e6, "kg", low_inclusive=False),
        "duration": Param(5.0, 0.0, 1e4, "s", low_inclusive=False),
    }
    # h |w| = 0.01 (slow) and 0.5 (fast) at the coarsest dt, 10 ms
    variants = {"slow": {}, "fast": {"spin": 50.0}}
    quick_variants = ("slow",)
    # the default run keeps the variant where every formulation's drift is far above
    # round-off (h|w| = 0.5); slow (h|w| = 0.01, with the order sweep) runs by name
    default_variants = ("fast",)

    def initial_orientation(self, p) -> np.ndarray:
        twist = rotation_quaternion(np.array([0.0, 0.0, TWIST]))
        tilt = rotation_quaternion(np.array([np.radians(p["tilt"]), 0.0, 0.0]))
        return quat_multiply(tilt, twist)

    def spin_vector(self, p) -> np.ndarray:
        """w (world) = |w| R0 e3: body axis 3 tilted by `tilt` from world z, about world x."""
        tilt = np.radians(p["tilt"])
        return p["spin"] * np.array([0.0, -np.sin(tilt), np.cos(tilt)])

    def exact_orientation(self, p, t) -> np.ndarray:
        """(T, 4): exp(t w / 2) (x) q0."""
        t = np.asarray(t, float)[:, None]
        return quat_multiply(rotation_quaternion(t * self.spin_vector(p)),
                             self.initial_orientation(p))

    def scene(self, p):
        body = RigidBodies(mass=[p["mass"]], inertia=[np.diag(PRINCIPAL_MOMENTS)],
                           position=[(0.0, 0.0, 1.0)],
                           orientation=[self.initial_orientation(p)],
                           velocity=[DRIFT_VELOCITY], angular_velocity=[self.spin_vector(p)])
        return Scene(parts=(body,))

    def t_end(self, p):
        return p["duration"]

    def dts(self, p):
        return [1e-2, 5e-3, 2.5e-3]

    def order_dts(self, p):
        """Coarser accuracy-only steps (h |w| up to 0.04 slow): a decade with the timed ones;
        none for the fast spin, whose coarsest timed step already turns 0.5 rad."""
        return [4e-2, 2e-2] if p["spin"] * 4e-2 <= 0.1 else []

    def reference_dt(self, p):
        return 2.5e-3

    def error_floor(self, p):
        return self._roundoff(p, min(self.dts(p)))[0]

    def motion_scale(self, p):
        """1 rad: the compared quantity is an angle error (at most pi); an error above 0.1
        rad (the error ceiling) is out of the asymptotic range."""
        return 1.0

    def observables(self, p, obs):
        q = self.first_body(obs, "q")
        w = self.first_body(obs, "w")
        exact = self.exact_orientation(p, np.asarray(obs["t"], float))
        return {"angle_error": rotation_angle_between(q, exact),
                "w_error": np.linalg.norm(w - self.spin_vector(p), axis=1)}

    def reference(self, p, t):
        zeros = np.zeros(len(np.asarray(t)))
        return {"angle_error": zeros, "w_error": zeros}

    def energy(self, p, obs):
        w_body = self.body_omega(obs)
        return 0.5 * np.sum(np.array(PRINCIPAL_MOMENTS) * w_body * w_body, axis=-1)

    def energy_scale(self, p):
        return 0.5 * PRINCIPAL_MOMENTS[2] * p["spin"] ** 2

    def extra_metrics(self, p, obs, observed, reference):
        return {"w_drift": float(np.max(observed["w_error"])) / p["spin"],
                **self.orientation_metrics(obs)}

    def _roundoff(self, p, dt):
        """S = 2 rad: rounding q's components to eps/2 each moves it by <= eps, the angle by
        <= 2 eps."""
        return roundoff_tolerance(int(round(p["duration"] / dt)), 2.0)

    def gyroscopic_rate(self, p) -> float:
        """lambda = |w| sqrt((I3 - I1)(I3 - I2) / (I1 I2)) (rad/s): a perturbation of w turns
        about the spin axis at lambda in the body frame (linearised Euler equations)."""
        return gyroscopic_rate(PRINCIPAL_MOMENTS, [0.0, 0.0, p["spin"]])

    def growth(self, integrator, p, dt) -> tuple[float, float, str]:
        """(log amplification per step of a perturbation of w, the rate mu at which that mode
        turns, why). The kick-drift steps act on the body-frame Euler equations (the drift
        turns the body about the new w, which leaves it unchanged): their step's growth on
        v' = B v at mu = lambda (symplectic Euler: explicit Euler, ln(1 + (lambda h)^2) / 2). The RK and implicit steps act on the world-frame w,
        where a body-frame perturbation turning at lambda turns at lambda and |w| + lambda: the
        larger log amplitude factor of the two (oscillator_rates; 0 where it damps)."""
        lam = self.gyroscopic_rate(p)
        if method_name(integrator) in KICK_METHODS:
            return kick_amplitude_rate(integrator, lam * dt), lam, (
                f"the kick-drift step's growth on the body-frame gyroscopic oscillation, "
                f"lambda = {lam:.3g} rad/s (_bounds.kick_amplitude_rate: ln(1 + (lambda h)^2) "
                "/ 2 a step for symplectic Euler, whose kick is explicit Euler on it)")
        candidates = []
        for mu in (lam, p["spin"] + lam):
            log_amp = oscillator_rates(integrator, mu * dt)[1]
            candidates.append((np.inf if not np.isfinite(log_amp) else max(log_amp, 0.0), mu))
        log_amp, mu = max(candidates)
        return log_amp, mu, (
            f"the method's log amplitude factor on the gyroscopic oscillation at lambda = "
            f"{lam:.3g} and at |w| + lambda = {p['spin'] + lam:.3g} rad/s (the world frame "
            "the steps act in), the larger, 0 where it damps")

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        """The exact discrete angle error n |step angle - h |w|| (the named method's turning
        at constant w in the formulation's chart, `_bounds.chart_step_angle`) + round-off:
        n eps S for the orientation, plus the roundings of w grown by the method's
        amplification of the gyroscopic oscillation (`seeded_growth`)."""
        steps = int(round(p["duration"] / dt))
        roundoff, roundoff_reason = self._roundoff(p, dt)
        rtol = adaptive_rtol(integrator)
        if rtol is not None:
            return 10 * rtol * p["spin"] * p["duration"] + roundoff, (
                "adaptive: local error held to rtol per step, the angle error after w t "
                "radians grows at most like w t rtol (factor 10 for the controller's safety "
                "margin)" + roundoff_reason)
        formulation = engine_variant or "quat_exp"
        y = p["spin"] * dt
        exact = steps * abs(chart_step_angle(integrator, formulation, y) - y)
        log_amp, mu, growth_reason = self.growth(integrator, p, dt)
        seeded = seeded_growth(log_amp, mu * dt, steps)
        grown = EPS * p["spin"] / self.gyroscopic_rate(p) * seeded
        reason = (f"order {order}, {formulation}: the exact discrete angle error n |step "
                  f"angle - y| = {exact:.3g} rad (y = h |w| = {y:.3g}, n = {steps}; w x I w = "
                  "0 keeps w exact, so each step turns by the method's angle in the chart: "
                  "_bounds.chart_step_angle, from its tableau or definition); plus the "
                  "roundings of w (eps |w| each) grown by rho = exp(alpha) a step, alpha = "
                  f"{log_amp:.3g}: {growth_reason}; the mode turns by mu h = {mu * dt:.3g} a "
                  "step against a rounding's fixed direction, so they sum to at most (rho^n + "
                  f"1) / |rho e^(i mu h) - 1| = {seeded:.3g} roundings, and tilt the spin by "
                  f"|dw| / lambda: {grown:.3g} rad")
        return exact + roundoff + grown, reason + roundoff_reason


def seeded_growth(log_amp, phase, steps) -> float:
    """(rho^n + 1) / |rho e^(i phase) - 1|, rho = exp(log_amp): a bound on |sum_k rho^(n-k)
    e^(i k phase)|, the sum of n unit seeds of one fixed direction added to a mode that grows
    by rho and turns by `phase` a step (inf when rho^n overflows)."""
    if not np.isfinite(log_amp) or steps * log_amp > 700.0:
        return np.inf
    rho = np.exp(log_amp)
    return float((rho ** steps + 1.0) / abs(rho * np.exp(1j * phase) - 1.0))


CASE = SpinDrift()
