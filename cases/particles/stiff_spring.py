"""Stiff spring: a mass on a linear spring to a fixed anchor, optionally damped.

m = 1 kg, default k = 1e4 N/m (variants sweep 1e2..1e6), released from rest at displacement A
along x. With w0 = sqrt(k/m) and damping ratio zeta = c / (2 sqrt(k m)), the displacement
u(t) = x(t) - L0 is, from u(0) = A, u'(0) = v0:
  under-damped (zeta < 1): e^{-zeta w0 t} (A cos wd t + (v0 + zeta w0 A)/wd sin wd t),
                           wd = w0 sqrt(1 - zeta^2);
  critically damped:       e^{-w0 t} (A + (v0 + w0 A) t);
  over-damped (zeta > 1):  c1 e^{r1 t} + c2 e^{r2 t}, r = -w0 (zeta -+ sqrt(zeta^2 - 1)).
Observable: `displacement` u (m). Energy m u'^2/2 + k u^2/2; with damping the reference energy is
the closed form's, so `energy_drift` is the integrator's error, scaled by E0 = k A^2 / 2.
Time steps are set by y = w0 dt, so the sweep means the same thing at every stiffness.
Source: the damped harmonic oscillator's closed forms (e.g. J. R. Taylor, Classical Mechanics,
2005, sec. 5.4, damped oscillations).
"""
from __future__ import annotations

import numpy as np

from refsim.case import (ADAPTIVE_REASON, Case, Param, adaptive_rtol, is_symplectic,
                         order_tolerance, roundoff_tolerance)
from refsim.scene import Body, Scene, Spring

Y_SWEEP = (0.2, 0.1, 0.05, 0.025)
Y_REFERENCE = 0.05
Y_ORDER_COARSE = 0.4  # the order >= 2 methods are still on their asymptotic slope here


class StiffSpring(Case):
    name = "stiff_spring"
    description = "mass on a stiff spring to a fixed anchor, k 1e2..1e6, optional damping"
    tags = ("particle", "spring", "stiff", "exact", "stability_probe")  # refsim stress runs it
    observable, units = "displacement", "m"
    params = {
        "mass": Param(1.0, 0.0, 1e6, "kg", low_inclusive=False),
        "stiffness": Param(1e4, 0.0, 1e9, "k (N/m)", low_inclusive=False),
        "zeta": Param(0.0, 0.0, 100.0, "damping ratio"),
        "amplitude": Param(0.1, 0.0, 10.0, "initial displacement A (m)", low_inclusive=False),
        "rest_length": Param(1.0, 0.0, 1e3, "L0 (m)", low_inclusive=False),
        "periods": Param(5.0, 0.0, 1e4, "duration in undamped periods", low_inclusive=False),
    }
    variants = {
        "default": {},
        "k=1e2": {"stiffness": 1e2},
        "k=1e6": {"stiffness": 1e6},
        "underdamped": {"zeta": 0.1},
        "critical": {"zeta": 1.0},
        "overdamped": {"zeta": 2.0},
    }
    # k = 1e2 (the soft end of the stiffness range; the default 1e4 and 1e6 bracket the
    # stiff behaviour) runs by name: the default run stays under 5 minutes with the rigid cases
    default_variants = ("default", "k=1e6", "underdamped", "critical", "overdamped")

    @staticmethod
    def omega(p):
        return np.sqrt(p["stiffness"] / p["mass"])

    def scene(self, p):
        c = 2.0 * p["zeta"] * np.sqrt(p["stiffness"] * p["mass"])
        body = Body(mass=p["mass"], position=(p["rest_length"] + p["amplitude"], 0.0, 0.0),
                    name="mass")
        spring = Spring(body=0, stiffness=p["stiffness"], rest_length=p["rest_length"],
                        damping=c)
        return Scene(bodies=(body,), springs=(spring,))

    def t_end(self, p):
        return p["periods"] * 2 * np.pi / self.omega(p)

    def dts(self, p):
        return [y / self.omega(p) for y in Y_SWEEP]

    def order_dts(self, p):
        """A coarser step for the convergence order only (accuracy pass, no timing): with the
        timed y = 0.2..0.025 it spans 0.4..0.025, 1.2 decades, for orders >= 2 (order 1 is
        asymptotic only below y ~ 0.05 and would need y = 0.005: 4x the run's steps)."""
        return [Y_ORDER_COARSE / self.omega(p)]

    def reference_dt(self, p):
        return Y_REFERENCE / self.omega(p)

    def observables(self, p, obs):
        return {"displacement": obs["x"][:, 0, 0] - p["rest_length"],
                "velocity": obs["v"][:, 0, 0]}

    def reference(self, p, t):
        u, v = damped_oscillator(self.omega(p), p["zeta"], p["amplitude"], 0.0, np.asarray(t))
        return {"displacement": u, "velocity": v}

    def energy(self, p, obs):
        o = self.observables(p, obs)
        return self._energy(p, o["displacement"], obs["v"][:, 0, :])

    def reference_energy(self, p, t):
        ref = self.reference(p, t)
        return 0.5 * p["mass"] * ref["velocity"] ** 2 + 0.5 * p["stiffness"] * \
            ref["displacement"] ** 2

    def _energy(self, p, u, v):
        return 0.5 * p["mass"] * np.sum(v * v, axis=-1) + 0.5 * p["stiffness"] * u ** 2

    def energy_scale(self, p):
        return 0.5 * p["stiffness"] * p["amplitude"] ** 2

    def motion_scale(self, p):
        return p["amplitude"]

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        w_t = self.omega(p) * self.t_end(p)
        rtol = adaptive_rtol(integrator)
        if rtol is not None:
            return 10 * rtol * p["amplitude"] * w_t, ADAPTIVE_REASON
        y = self.omega(p) * dt
        symplectic = is_symplectic(settings)
        # the state x = L0 + u, |x| <= L0 + A, and v, |v| / w0 <= A: rounding both errs by at
        # most eps/2 (L0 + 2A) in u (a linear oscillation keeps it, neither grown nor damped)
        roundoff, roundoff_reason = roundoff_tolerance(
            int(round(self.t_end(p) / dt)), 0.5 * (p["rest_length"] + 2 * p["amplitude"]))
        tol = order_tolerance(p["amplitude"], w_t, y, order, symplectic) + roundoff
        form = ("A ((w0 dt)^p + w0 t (w0 dt)^q), q = 2 ceil(p/2)" if symplectic
                else "A expm1(w0 t (w0 dt)^p)")
        return tol, (f"order {order}{', symplectic' if symplectic else ''}: {form}, the global "
                     "error bound of such a method after w0 t radians (see order_tolerance)"
                     + roundoff_reason)

    def stability(self, p):
        """`refsim stress`: y = omega dt on the undamped spring from rest, the amplitude lowered
        from 0.1 m to 1e-7 m so that the mass never reaches the anchor and the spring stays
        linear at every y searched (refsim.stress_search's docstring says why)."""
        from refsim.stress_spec import oscillator_spec
        return oscillator_spec(self.omega(p), 0.0, self.energy_scale(p),
                               "linear stability of the stepper on u'' = -w0^2 u (Hairer, "
                               "Lubich & Wanner 2006; Butcher 2016 for RK stability "
                               "polynomials)", {"amplitude": 1e-7}, batch=True)


def damped_oscillator(w0, zeta, u0, v0, t):
    """Exact (u, u') of u'' + 2 zeta w0 u' + w0^2 u = 0."""
    if zeta < 1.0:
        wd = w0 * np.sqrt(1.0 - zeta * zeta)
        b = (v0 + zeta * w0 * u0) / wd
        decay = np.exp(-zeta * w0 * t)
        cos, sin = np.cos(wd * t), np.sin(wd * t)
        u = decay * (u0 * cos + b * sin)
        v = decay * ((b * wd - zeta * w0 * u0) * cos - (u0 * wd + zeta * w0 * b) * sin)
        return u, v
    if zeta == 1.0:
        b = v0 + w0 * u0
        decay = np.exp(-w0 * t)
        return decay * (u0 + b * t), decay * (b - w0 * (u0 + b * t))
    root = np.sqrt(zeta * zeta - 1.0)
    r1, r2 = -w0 * (zeta - root), -w0 * (zeta + root)
    c2 = (v0 - r1 * u0) / (r2 - r1)
    c1 = u0 - c2
    e1, e2 = np.exp(r1 * t), np.exp(r2 * t)
    return c1 * e1 + c2 * e2, c1 * r1 * e1 + c2 * r2 * e2


CASE = StiffSpring()
