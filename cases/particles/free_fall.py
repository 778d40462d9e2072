"""Free fall: a point mass from (x0, v0) under gravity, with optional linear drag f = -b v.

Reference (closed form): without drag x(t) = x0 + v0 t + g t^2 / 2; with drag, tau = m / b and
terminal velocity v_inf = g tau, v(t) = v_inf + (v0 - v_inf) e^{-t/tau},
x(t) = x0 + v_inf t + (v0 - v_inf) tau (1 - e^{-t/tau}).
Observable: `position` (m, the 3-vector; error is its Euclidean norm). Energy: m |v|^2/2 - m g.x
(drag removes energy: the reference energy is the closed form's, so `energy_drift` measures the
integrator, not the physics).
Source: Newton's second law with a force linear in v, integrated in closed form (e.g. J. R.
Taylor, Classical Mechanics, 2005, sec. 2.2, linear air resistance).
"""
from __future__ import annotations

import numpy as np

from refsim.case import ADAPTIVE_REASON, Case, Param, adaptive_rtol, roundoff_tolerance
from refsim.scene import Body, Scene


class FreeFall(Case):
    name = "free_fall"
    description = "point mass under gravity from (x0, v0), optional linear drag; closed form"
    tags = ("particle", "gravity", "exact")
    observable, units = "position", "m"
    params = {
        "mass": Param(1.0, 0.0, 1e6, "kg", low_inclusive=False),
        "height": Param(10.0, -1e6, 1e6, "initial z (m)"),
        "vx0": Param(1.0, -1e4, 1e4, "initial x velocity (m/s)"),
        "vz0": Param(5.0, -1e4, 1e4, "initial z velocity (m/s)"),
        "g": Param(9.81, 0.0, 1e3, "gravity (m/s^2)"),
        "drag": Param(0.0, 0.0, 1e6, "linear drag coefficient b (kg/s)"),
        "duration": Param(2.0, 0.0, 1e4, "s", low_inclusive=False),
    }
    variants = {"default": {}, "drag": {"drag": 0.5}}

    def scene(self, p):
        body = Body(mass=p["mass"], position=(0.0, 0.0, p["height"]),
                    velocity=(p["vx0"], 0.0, p["vz0"]), name="ball")
        return Scene(bodies=(body,), gravity=(0.0, 0.0, -p["g"]), linear_drag=p["drag"])

    def t_end(self, p):
        return p["duration"]

    def dts(self, p):
        """Timed steps. (0.5 ms, timed until issue 12, went: the order sweep's 1..250 ms
        spans the decade it gave, and its timing passes paid for the untimed order_dts.)"""
        return [4e-3, 2e-3, 1e-3]

    def order_dts(self, p):
        """Coarser steps for the convergence order only (accuracy pass, no timing): an order-4
        method on the drag variant (tau = 2 s) errs 4e-12 at 4 ms, below the floor; at
        15.6..250 ms (dt/tau <= 1/8) it errs 6e-10..4e-5 on its asymptotic slope."""
        return [0.25, 0.0625, 0.015625]

    def error_floor(self, p):
        """Round-off: the closed form is exact to a few eps of the motion scale, and the
        integrators' round-off after 4000 steps (dt = 0.5 ms) is <= 3e-12 (measured, motion
        scale 40 m): taken 1e-12 of the motion scale."""
        return 1e-12 * self.motion_scale(p)

    def reference_dt(self, p):
        return 1e-3

    def observables(self, p, obs):
        return {"position": obs["x"][:, 0, :], "velocity": obs["v"][:, 0, :]}

    def reference(self, p, t):
        t = np.asarray(t, float)[:, None]
        x0 = np.array([0.0, 0.0, p["height"]])
        v0 = np.array([p["vx0"], 0.0, p["vz0"]])
        g = np.array([0.0, 0.0, -p["g"]])
        if p["drag"] == 0:
            return {"position": x0 + v0 * t + 0.5 * g * t ** 2, "velocity": v0 + g * t}
        tau = p["mass"] / p["drag"]
        v_inf = g * tau
        decay = -np.expm1(-t / tau)  # 1 - e^{-t/tau}, accurate for small t/tau
        return {"position": x0 + v_inf * t + (v0 - v_inf) * tau * decay,
                "velocity": v0 + (v_inf - v0) * decay}

    def energy(self, p, obs):
        return self._energy(p, obs["x"][:, 0, :], obs["v"][:, 0, :])

    def reference_energy(self, p, t):
        ref = self.reference(p, t)
        return self._energy(p, ref["position"], ref["velocity"])

    def _energy(self, p, x, v):
        return p["mass"] * (0.5 * np.sum(v * v, axis=-1) + p["g"] * x[:, 2])

    def energy_scale(self, p):
        return p["mass"] * (0.5 * (p["vx0"] ** 2 + p["vz0"] ** 2) + p["g"] * abs(p["height"])) \
            or 1.0

    def motion_scale(self, p):
        t = p["duration"]
        return abs(p["height"]) + np.hypot(p["vx0"], p["vz0"]) * t + 0.5 * p["g"] * t * t

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        t = p["duration"]
        a_max = p["g"] + p["drag"] / p["mass"] * np.hypot(p["vx0"], p["vz0"])
        scale = self.motion_scale(p)
        # |x| <= scale; a velocity rounding eps/2 |v|, |v| <= |v0| + g t, is carried over at
        # most t: eps/2 (|v0| t + g t^2) <= eps scale. One rounding: at most 1.5 eps scale
        roundoff, roundoff_reason = roundoff_tolerance(max(1, int(round(t / dt))), 1.5 * scale)
        rtol = adaptive_rtol(integrator)
        if rtol is not None and p["drag"] > 0:
            return 10 * rtol * scale * max(1.0, t * p["drag"] / p["mass"]) + roundoff, \
                ADAPTIVE_REASON + roundoff_reason
        if p["drag"] == 0 and order >= 2:
            return roundoff, ("exact for any method of order >= 2 (x is quadratic in t): "
                              "round-off only" + roundoff_reason)
        if order == 1 or p["drag"] == 0:
            return a_max * t * dt / 2 + roundoff, ("first order: the error of every Euler step "
                                                  "on constant acceleration is a t dt / 2"
                                                  + roundoff_reason)
        tau = p["mass"] / p["drag"]
        return a_max * t * dt ** order / tau ** (order - 1) + roundoff, (
            f"order {order} on an exponential of time constant tau: a_max t dt^p / tau^(p-1) "
            "(leading error constant taken as 1)" + roundoff_reason)


CASE = FreeFall()
