"""Dzhanibekov (tennis-racket) flip: a torque-free asymmetric top spun about its intermediate axis.

Principal moments I1 < I2 < I3 (the body-frame inertia diag(I1, I2, I3)), no gravity, no torque.
Closed form (Landau & Lifshitz, Mechanics, sec. 37) for L^2 > 2 E I2, with body angular velocity
  w1 = A1 cn(tau | m), w2 = A2 sn(tau | m), w3 = A3 dn(tau | m),
  A1 = sqrt((2 E I3 - L^2) / (I1 (I3 - I1))), A2 = sqrt((2 E I3 - L^2) / (I2 (I3 - I2))),
  A3 = sqrt((L^2 - 2 E I1) / (I3 (I3 - I1))), tau = rate t + K(m),
  rate = sqrt((I3 - I2) (L^2 - 2 E I1) / (I1 I2 I3)),
  m = k^2 = (I2 - I1) (2 E I3 - L^2) / ((I3 - I2) (L^2 - 2 E I1)),
scipy's `ellipj(u, m)` taking the parameter m = k^2, u reduced modulo the period 4K. The time
shift K(m) starts the body at sn = 1: w_body(0) = (0, W, A3 sqrt(1 - m)), spinning about the
intermediate axis with a small component on axis 3; w2 changes sign (the flip) at rate t = K and
back at rate t = 3K, so one period 4K/rate holds two flips. The body's attitude at t = 0 is a
fixed general rotation (no body axis along a world axis), so an engine that mixes the body and
world frames fails; the centre of mass drifts at a constant velocity (free flight).
Observables: `w_body` = R^T w (rad/s, compared; also `w1`..`w3`) and the world `L` = R I0 R^T w.
Conserved: E = 1/2 w . L and the world L; `momentum_drift` = max |L(t) - L0| / |L0| and
`orientation_drift` = max |orientation_defect| are reported.
"""
from __future__ import annotations

import numpy as np
from scipy.special import ellipe, ellipj, ellipk

from refsim.case import ADAPTIVE_REASON, Param, adaptive_rtol, roundoff_tolerance
from refsim.scene import RigidBodies, Scene

from . import RigidCase, quat_to_matrix, rotation_quaternion
from ._bounds import (KICK_METHODS, KICK_REASON, PRINTED_REASON, gyroscopic_rate, method_name,
                      mode_error)

# attitude at t = 0: the rotation by 1.15 rad about (0.6, -0.9, 0.4)/|.|, no axis left in place
INITIAL_ROTATION_VECTOR = (0.6, -0.9, 0.4)
NEAR_SEPARATRIX_K2 = 1.0 - 1e-4
DRIFT_VELOCITY = (0.1, -0.05, 0.02)  # m/s, the centre of mass's free flight
SAFETY = 2.0  # the one safety factor of the bound (tolerance)


def moments(p) -> np.ndarray:
    inertia = np.array([p["I1"], p["I2"], p["I3"]])
    if not (inertia[0] < inertia[1] < inertia[2]):
        raise ValueError(f"dzhanibekov moments must satisfy I1 < I2 < I3, got I1 = {p['I1']}, "
                         f"I2 = {p['I2']}, I3 = {p['I3']}")
    return inertia


def initial_body_omega(p) -> np.ndarray:
    """w_body(0) = (0, W, w3) with w3 chosen so that k^2 = m: at w1 = 0,
    m = I2 (I2 - I1) W^2 / (I2 (I2 - I1) W^2 + I3 (I3 - I1) w3^2)."""
    i1, i2, i3 = moments(p)
    spin, m = p["spin"], p["k2"]
    w3 = spin * np.sqrt((1.0 - m) / m * i2 * (i2 - i1) / (i3 * (i3 - i1)))
    return np.array([0.0, spin, w3])


def invariants(p) -> dict:
    """E, L^2, amplitudes, rate, m and K(m) of the closed form (from the initial state)."""
    i1, i2, i3 = inertia = moments(p)
    w0 = initial_body_omega(p)
    energy2, l2 = float(np.sum(inertia * w0 ** 2)), float(np.sum((inertia * w0) ** 2))
    top, bottom = energy2 * i3 - l2, l2 - energy2 * i1  # 2 E I3 - L^2 > 0, L^2 - 2 E I1 > 0
    m = (i2 - i1) * top / ((i3 - i2) * bottom)
    amplitudes = np.sqrt([top / (i1 * (i3 - i1)), top / (i2 * (i3 - i2)),
                          bottom / (i3 * (i3 - i1))])
    return {"E": 0.5 * energy2, "L2": l2, "top": top, "bottom": bottom, "m": m,
            "K": float(ellipk(m)), "amplitudes": amplitudes,
            "rate": float(np.sqrt((i3 - i2) * bottom / (i1 * i2 * i3)))}


def exact_body_omega(p, t) -> np.ndarray:
    """(T, 3) closed-form body angular velocity at times t."""
    c = invariants(p)
    u = np.mod(c["rate"] * np.asarray(t, float) + c["K"], 4.0 * c["K"])
    sn, cn, dn, _ = ellipj(u, c["m"])
    return np.stack([cn, sn, dn], axis=-1) * c["amplitudes"]


def flip_period(p) -> float:
    """Period of w_body: 4 K(m) / rate (two flips)."""
    c = invariants(p)
    return 4.0 * c["K"] / c["rate"]


def initial_orientation() -> np.ndarray:
    return rotation_quaternion(np.array(INITIAL_ROTATION_VECTOR))


def world_momentum(p) -> np.ndarray:
    """L0 = R0 I0 w_body(0), constant in the world frame."""
    return quat_to_matrix(initial_orientation()) @ (moments(p) * initial_body_omega(p))


def period_sensitivity(p) -> float:
    """max over the orbit of |grad_w ln T| Wmax, T = 4 K(m) / rate the flip period: a state
    error dw shifts the phase tau = rate t by rate t |grad ln T| |dw| per unit rate t, and
    w_body moves by at most Wmax = |(A1, A2, A3)| per unit tau (|d(cn, sn, dn)/dtau| <= 1).
    With a = 2 E I3 - L^2 = sum I_i (I3 - I_i) w_i^2 and b = L^2 - 2 E I1 = sum I_i (I_i - I1)
    w_i^2: ln m = ln a - ln b + const, ln rate = ln b / 2 + const, and dlnK/dm = (E(m) -
    (1 - m) K) / (2 m (1 - m) K) (Byrd & Friedman 710.00). Near the separatrix dlnK/dm ~
    1 / (2 (1 - m) K) makes it large: the flip's timing is what a small error changes most.
    Dimensionless; the max is taken over 256 points of one period of the closed form."""
    c = invariants(p)
    inertia = moments(p)
    w = exact_body_omega(p, np.linspace(0.0, flip_period(p), 256, endpoint=False))
    grad_a = 2.0 * inertia * (inertia[2] - inertia) * w / c["top"]
    grad_b = 2.0 * inertia * (inertia - inertia[0]) * w / c["bottom"]
    m = c["m"]
    dlnk_dm = (ellipe(m) - (1.0 - m) * c["K"]) / (2.0 * m * (1.0 - m) * c["K"])
    grad_ln_period = dlnk_dm * m * (grad_a - grad_b) - 0.5 * grad_b
    return float(np.max(np.linalg.norm(grad_ln_period, axis=1)) * np.linalg.norm(c["amplitudes"]))


class Dzhanibekov(RigidCase):
    name = "dzhanibekov"
    description = ("torque-free asymmetric top spun about its intermediate axis: the flip, "
                   "Jacobi-elliptic closed form; world L and E conserved")
    tags = ("rigid", "rotation", "exact")
    observable, units = "w_body", "rad/s"
    params = {
        "I1": Param(1.0, 0.0, 1e6, "smallest principal moment (kg m^2)", low_inclusive=False),
        "I2": Param(2.0, 0.0, 1e6, "intermediate principal moment (kg m^2)",
                    low_inclusive=False),
        "I3": Param(3.0, 0.0, 1e6, "largest principal moment (kg m^2)", low_inclusive=False),
        "k2": Param(0.5, 0.0, 1.0 - 1e-9, "elliptic parameter m = k^2 in (0, 1): 1 is the "
                    "separatrix", low_inclusive=False),
        "spin": Param(1.0, 0.0, 1e3, "initial body spin W about the intermediate axis (rad/s)",
                      low_inclusive=False),
        "mass": Param(1.0, 0.0, 1e6, "kg", low_inclusive=False),
        "periods": Param(1.0, 0.0, 100.0, "duration in flip periods 4K/rate (two flips each)",
                         low_inclusive=False),
    }
    variants = {"far": {}, "near_separatrix": {"k2": NEAR_SEPARATRIX_K2}}
    quick_variants = ("far",)
    # near the separatrix a run is 4151..8302 steps (RK4 at 0.5 ms/step in refsim: 4 s a row):
    # run by name (--variant near_separatrix), outside the 5-minute default run
    default_variants = ("far",)

    def scene(self, p):
        inertia = np.diag(moments(p))
        q0 = initial_orientation()
        body = RigidBodies(mass=[p["mass"]], inertia=[inertia], position=[(0.0, 0.0, 0.0)],
                           orientation=[q0], velocity=[DRIFT_VELOCITY],
                           angular_velocity=[quat_to_matrix(q0) @ initial_body_omega(p)])
        return Scene(parts=(body,))

    def t_end(self, p):
        return p["periods"] * flip_period(p)

    def dts(self, p):
        """far: 454..1817 steps a period (Wmax dt = 0.033..0.008); near the separatrix the
        period is 4.6x longer and the flip 2.4x faster in rate: 4151..8302 steps (Wmax dt =
        0.015..0.008)."""
        return [1e-2, 5e-3] if self._near(p) else [2e-2, 1e-2, 5e-3]

    def order_dts(self, p):
        """Coarser accuracy-only steps so the order fit spans a decade (Wmax dt up to 0.13
        far, 0.06 near: an order-4 error stays on its slope above the floor)."""
        return [4e-2, 2e-2] if self._near(p) else [8e-2, 4e-2]

    def reference_dt(self, p):
        return 5e-3 if self._near(p) else 1e-2

    @staticmethod
    def _near(p):
        return p["k2"] > 0.99

    def error_floor(self, p):
        """Round-off: n eps Wmax per step over the finest run's <= 8302 steps, times the
        phase amplification (1 + S rate t) of `period_sensitivity`: 1e-11 far, 2e-7 near."""
        steps = self.t_end(p) / min(self.dts(p))
        return steps * 2.2e-16 * self.motion_scale(p) * self._amplification(p)

    def observables(self, p, obs):
        w_body = self.body_omega(obs)
        rotation = quat_to_matrix(self.first_body(obs, "q"))
        momentum = np.einsum("tij,tj->ti", rotation, moments(p) * w_body)
        return {"w_body": w_body, "w1": w_body[:, 0], "w2": w_body[:, 1], "w3": w_body[:, 2],
                "L": momentum}

    def reference(self, p, t):
        w_body = exact_body_omega(p, t)
        momentum = np.broadcast_to(world_momentum(p), w_body.shape)
        return {"w_body": w_body, "w1": w_body[:, 0], "w2": w_body[:, 1], "w3": w_body[:, 2],
                "L": momentum}

    def energy(self, p, obs):
        w_body = self.body_omega(obs)
        return 0.5 * np.sum(moments(p) * w_body * w_body, axis=-1)

    def energy_scale(self, p):
        return invariants(p)["E"]

    def motion_scale(self, p):
        """|w_body(0)| (rad/s): the size of the compared angular velocity."""
        return float(np.linalg.norm(initial_body_omega(p)))

    def extra_metrics(self, p, obs, observed, reference):
        momentum0 = world_momentum(p)
        drift = np.linalg.norm(observed["L"] - momentum0, axis=1) / np.linalg.norm(momentum0)
        return {"momentum_drift": float(np.max(drift)), **self.orientation_metrics(obs)}

    def _amplification(self, p):
        return 1.0 + period_sensitivity(p) * invariants(p)["rate"] * self.t_end(p)

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        """SAFETY x |w0| n (|phi(y)| + |alpha(y)| (1 + G/2)), y = max|w| h, n = t / h: the
        named method's phase and amplitude errors per step on an oscillation at the body's
        angular speed (`_bounds.mode_error`, from its stability function), G = S rate t the
        flip-timing gain of an energy error; plus the kick-drift and printed-matrix terms and
        round-off times 1 + G."""
        scale, gain = self.motion_scale(p), self._amplification(p) - 1.0
        rtol = adaptive_rtol(integrator)
        if rtol is not None:
            omega_t = max(float(np.linalg.norm(invariants(p)["amplitudes"])),
                          invariants(p)["rate"]) * self.t_end(p)
            return 10 * rtol * scale * omega_t * (1.0 + gain), ADAPTIVE_REASON + (
                f", times the flip-timing amplification 1 + S rate t = {1.0 + gain:.3g}")
        speed, kick = orbit_rates(p)
        steps = self.t_end(p) / dt
        printed = engine_variant == "matrix_printed"
        bound = SAFETY * mode_error(integrator, [(scale, speed)], dt, steps, gain,
                                    kick=(scale, kick),
                                    printed=(scale, speed) if printed else None)
        roundoff, roundoff_reason = roundoff_tolerance(int(round(steps)), scale)
        reason = (f"order {order}: {SAFETY:g} |w0| n (|phi(y)| + |alpha(y)| (1 + G/2)), y = "
                  f"max|w| h = {speed * dt:.3g}, n = {steps:.0f}: the method's phase and "
                  "amplitude errors per step (refsim.expected.oscillator_rates) on the world "
                  f"angular velocity, which turns with the body at up to max|w| = {speed:.3g} "
                  f"rad/s (amplitude |w0| = {scale:.3g}); G = S rate t = {gain:.3g} the "
                  "flip-timing gain of an energy error (period_sensitivity), half of it over a "
                  f"linearly growing error; safety factor {SAFETY:g}")
        if method_name(integrator) in KICK_METHODS:
            reason += KICK_REASON.format(rate=kick, amplitude=scale)
        if printed:
            reason += PRINTED_REASON.format(rate=speed)
        return bound + roundoff * (1.0 + gain), reason + roundoff_reason + (
            f", times 1 + G = {1.0 + gain:.3g}")


def orbit_rates(p) -> tuple[float, float]:
    """(max |w|, the gyroscopic rate) over one period of the closed form (256 points): the
    body's fastest turning, and the largest spectral radius of the gyroscopic term's Jacobian
    (`_bounds.gyroscopic_rate`)."""
    w = exact_body_omega(p, np.linspace(0.0, flip_period(p), 256, endpoint=False))
    return float(np.max(np.linalg.norm(w, axis=1))), gyroscopic_rate(moments(p), w)


CASE = Dzhanibekov()
