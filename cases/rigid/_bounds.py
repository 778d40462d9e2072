"""Error bounds of the named refsim methods on the rigid cases' motions, from each method's
stability function (`refsim.expected.oscillator_rates`): shared by the rigid cases.

A rigid case's compared observable moves as a sum of oscillations ("modes") of amplitude a_k
at frequency w_k: the body's turning at its angular speed, a precession, a nutation, a swing.
On the oscillation x'' = -w^2 x the named method errs per step by its phase error phi(y) and its
log amplitude factor alpha(y), y = w h, exactly (the principal eigenvalue of its step matrix,
written from its tableau or definition): after n steps a mode errs by a n |phi| in phase and
a n |alpha| in amplitude (`mode_error`). A non-conserving method's amplitude (energy) error
also changes the motion's period where the period depends on it: a relative error growing
linearly to n |alpha| shifts the phase by (G / 2) n |alpha|, G = the case's stated phase gain
(dlnT/dlnE w t for a pendulum, S rate t for the free top's flip). A case multiplies the sum by
its one stated safety factor (<= 3) and adds its round-off term.

Two properties of refsim's rigid steppers enter as formulation terms, both stated in reasons:
- the kick-drift methods (symplectic Euler, Verlet, leapfrog) evaluate the gyroscopic torque
  w x I w at the old w: on that term they are explicit Euler, whose amplitude factor
  (1 + h^2 |w x L|^2 / |L|^2)^(1/2) raises |L| every step (`KICK_REASON`);
- `matrix_printed`, R + h [w]_x R, is explicit Euler on R' = [w]_x R: it stretches R by
  (1 + y^2)^(1/2) a step in the plane normal to w, y = |w| h (first order, any stepper;
  `PRINTED_REASON`).
"""
from __future__ import annotations

import numpy as np

from refsim.expected import discrete_solution, has_discrete_solution, maps, oscillator_rates
from refsim.integrators.spec import spec_name

KICK_METHODS = ("symplectic_euler", "symplectic_euler_dk", "velocity_verlet", "stormer_verlet",
                "leapfrog")
KICK_REASON = ("; the kick-drift step evaluates the gyroscopic torque w x I w at the old w: "
               "the oscillation it drives (lambda = {rate:.3g} rad/s, the gyroscopic Jacobian's "
               "spectral radius) grows by the step's spectral radius on v' = B v "
               "(kick_amplitude_rate; symplectic Euler (1 + (lambda h)^2)^(1/2), explicit "
               "Euler's): {amplitude:.3g} n log of it")
PRINTED_REASON = ("; matrix_printed: R + h [w]_x R is explicit Euler on R' = [w]_x R, no "
                  "repair: R stretches by (1 + y^2)^(1/2) a step normal to w (y = |w| h, "
                  "first order whatever the stepper), an amplitude term at {rate:.3g} rad/s")


def method_name(spec: str) -> str:
    return spec_name(spec)


def per_step_rates(spec: str, y: float) -> tuple[float, float]:
    """(|phase error|, |log amplitude factor|) per step of the named method at y = w h; inf
    where the method has no oscillatory solution there (beyond its stability range)."""
    if not has_discrete_solution(spec):
        raise ValueError(f"per_step_rates needs a fixed-step refsim method, got {spec!r}")
    if y == 0:
        return 0.0, 0.0
    phase, amplitude = oscillator_rates(spec, y)
    if not (np.isfinite(phase) and np.isfinite(amplitude)):
        return np.inf, np.inf
    return abs(phase), abs(amplitude)


def euler_amplitude_rate(y: float) -> float:
    """log |1 + i y| = ln(1 + y^2) / 2: explicit Euler's amplitude factor per step."""
    return 0.5 * float(np.log1p(y * y))


def mode_error(spec: str, modes, dt: float, steps: float, gain: float = 0.0,
               kick=None, printed=None) -> float:
    """sum over modes (a, w) of a n (|phi(w h)| + |alpha(w h)| (1 + G/2)): the global error of
    the named method on those oscillations after n = `steps` steps (module docstring); plus,
    for a kick-drift method, a n ln(1 + (w h)^2) / 2 for `kick` = (a, w), the explicit
    gyroscopic term's amplitude growth (not amplified by G: it is an amplitude error of the
    gyroscopic oscillation), and for `printed` = (a, w[, G_p]) the printed matrix's stretch
    a n ln(1 + (w h)^2) / 2 (1 + G_p/2), G_p = G unless the case states the stretch's own."""
    growth = 1.0 + 0.5 * gain
    total = 0.0
    for amplitude, rate in modes:
        phase, log_amp = per_step_rates(spec, rate * dt)
        total += amplitude * steps * (phase + log_amp * growth)
    if kick is not None and method_name(spec) in KICK_METHODS:
        total += kick[0] * steps * kick_amplitude_rate(spec, kick[1] * dt)
    if printed is not None:  # (a, w) or (a, w, its own phase gain)
        own = growth if len(printed) < 3 else 1.0 + 0.5 * printed[2]
        total += printed[0] * steps * euler_amplitude_rate(printed[1] * dt) * own
    return total


def kick_amplitude_rate(spec: str, y: float) -> float:
    """log of the spectral radius of the named kick-drift method's step on the pure gyroscopic
    rotation v' = B v, B = lambda J (J the quarter turn), at y = lambda h (refsim.expected.maps,
    written from each method's definition with refsim's one-correction rule): ln(1 + y^2) / 2
    for symplectic Euler (its kick is explicit Euler on B), O(y^4) for velocity Verlet."""
    turn = np.array([[0.0, -y], [y, 0.0]])
    _, step, _ = maps(spec, np.zeros((2, 2)), turn, 1.0)
    return max(float(np.log(np.max(np.abs(np.linalg.eigvals(step))))), 0.0)


def gyroscopic_rate(inertia, w_body) -> float:
    """max over the rows w of the spectral radius of d/dw [-I^-1 (w x I w)] (body frame,
    principal moments `inertia`): the fastest oscillation the gyroscopic term drives (for a
    spin W about axis 3, W sqrt((I3 - I1)(I3 - I2) / (I1 I2)))."""
    inertia = np.asarray(inertia, float)
    w = np.atleast_2d(np.asarray(w_body, float))

    def skew(a):
        z = np.zeros(len(a))
        return np.stack([np.stack([z, -a[:, 2], a[:, 1]], -1),
                         np.stack([a[:, 2], z, -a[:, 0]], -1),
                         np.stack([-a[:, 1], a[:, 0], z], -1)], -2)
    jac = -(skew(w) * inertia[None, None, :] - skew(inertia * w)) / inertia[None, :, None]
    return float(np.max(np.abs(np.linalg.eigvals(jac))))


def chart_error(spec: str, formulation: str, amplitude: float, rate: float, dt: float,
                steps: float) -> float:
    """a n |chart_step_angle(y) - y|, y = w h: the turning error the formulation's chart adds
    over the run (0 for the exponential map), times the observable's sensitivity a to a
    rotation about w."""
    y = rate * dt
    return amplitude * steps * abs(chart_step_angle(spec, formulation, y) - y)


def linear_swing_error(spec: str, amplitude: float, rate: float, dt: float, steps: int) -> float:
    """max over the run of |x_k - a cos(w t_k)|: the exact discrete solution of the named method
    on the linearised swing x'' = -w^2 x from rest at a (`refsim.expected.discrete_solution`),
    its shape, phase and amplitude errors together, at every step."""
    k = np.arange(1, int(steps) + 1)
    x, _ = discrete_solution(spec, -rate * rate, None, [amplitude], [0.0], dt, k)
    return float(np.max(np.abs(x[:, 0] - amplitude * np.cos(rate * dt * k))))


# the turning per step of a formulation's chart at constant w (|w| h = y), for parallel stage
# vectors: the chart's angle g(X) of an increment X, and its inverse differential's factor
# on a parallel vector, d(X) (rigid_orientation: dexp^-1 1, dcay^-1 1 + X^2/4, dpolar^-1
# 1 + X^2; the printed matrix has none)
CHARTS = {"quat_exp": (lambda x: x, lambda x: 1.0),
          "quat_normalised": (lambda x: 2.0 * np.arctan(0.5 * x), lambda x: 1.0 + 0.25 * x * x),
          "matrix_polar": (np.arctan, lambda x: 1.0 + x * x),
          "matrix_printed": (np.arctan, None)}


def chart_step_angle(spec: str, formulation: str, y: float) -> float:
    """The angle one step of the named method turns a body spinning at constant w (y = |w| h)
    in the formulation's chart: explicit RK (RKMK) k_1 = 1, x_i = y sum_j a_ij k_j, k_i = d(x_i),
    X = y sum_i b_i k_i; the implicit midpoint k = d(y k / 2), X = y k; the kick-drift and
    implicit one-stage steps X = y (w is exact); the angle is g(X) (CHARTS)."""
    from refsim.integrators import get_integrator
    angle, factor = CHARTS.get(formulation, CHARTS["quat_exp"])
    stepper = get_integrator(spec)
    tableau = getattr(stepper, "tableau", None)
    if factor is None or (tableau is None and method_name(spec) != "implicit_midpoint"):
        return float(angle(y))
    if tableau is None:  # implicit midpoint: the fixed point k = d(y k / 2)
        k = 1.0
        for _ in range(100):
            k = factor(0.5 * y * k)
        # refsim's solver stops when V converges, which at constant w is after its first sweep:
        # its K is d applied twice, d(y d(y / 2) / 2), off the fixed point by O(y^4): the
        # larger of the two turning errors (ImplicitMidpoint's tol covers V, not K)
        swept = factor(0.5 * y * factor(0.5 * y))
        return max((float(angle(y * k)), float(angle(y * swept))), key=lambda a: abs(a - y))
    a, b, _ = tableau.arrays()
    k = []
    for i in range(len(b)):
        k.append(factor(y * sum(a[i, j] * k[j] for j in range(i))) if i else 1.0)
    return float(angle(y * sum(b[i] * k[i] for i in range(len(b)))))
