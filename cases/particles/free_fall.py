"""Free fall: a point mass from (x0, v0) under gravity, with optional linear drag f = -b v.

Default mass 2 kg (not 1, so that an engine forgetting to divide the drag, or a gravity force
m g, by the mass fails); the drag variant's b = 1 kg/s gives tau = m / b = 2 s.
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

from refsim.case import Case, Param, adaptive_rtol, roundoff_tolerance, sample_steps
from refsim.expected import discrete_solution
from refsim.scene import Body, Particles, Scene

from .stiff_spring import adaptive_bound


class FreeFall(Case):
    name = "free_fall"
    description = "point mass under gravity from (x0, v0), optional linear drag; closed form"
    tags = ("particle", "gravity", "exact")
    observable, units = "position", "m"
    params = {
        "mass": Param(2.0, 0.0, 1e6, "kg", low_inclusive=False),
        "height": Param(10.0, -1e6, 1e6, "initial z (m)"),
        "vx0": Param(1.0, -1e4, 1e4, "initial x velocity (m/s)"),
        "vz0": Param(5.0, -1e4, 1e4, "initial z velocity (m/s)"),
        "g": Param(9.81, 0.0, 1e3, "gravity (m/s^2)"),
        "drag": Param(0.0, 0.0, 1e6, "linear drag coefficient b (kg/s)"),
        "duration": Param(2.0, 0.0, 1e4, "s", low_inclusive=False),
    }
    variants = {"default": {}, "drag": {"drag": 1.0}}

    def scene(self, p):
        body = Body(mass=p["mass"], position=(0.0, 0.0, p["height"]),
                    velocity=(p["vx0"], 0.0, p["vz0"]), name="ball")
        return Scene(parts=(Particles.of((body,)),), gravity=(0.0, 0.0, -p["g"]),
                     linear_drag=p["drag"])

    def t_end(self, p):
        return p["duration"]

    def dts(self, p):
        """Timed steps. (0.5 ms, timed until issue 12, went: the order sweep's 1..250 ms
        spans the decade it gave, and its timing passes paid for the untimed order_dts.)"""
        return [4e-3, 2e-3, 1e-3]

    def order_dts(self, p):
        """Coarser steps for the convergence order only (accuracy pass, no timing): an order-4
        method on the drag variant (tau = m / b = 2 s) errs 4e-12 at 4 ms, below the floor; at
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
        """The named method's own error: its exact discrete solution (refsim.expected) on
        x'' = -(b/m) v + g, made linear by a constant coordinate s = 1 (x'' = A x + B v with
        A's column for s holding g), against the closed form, max over the samples the
        harness observes (err_max), plus round-off. (Without drag every method of order >= 2
        is exact on the quadratic and Euler's steps err k (k +- 1) dt^2 g / 2: the discrete
        solution gives both.) dopri5_adaptive: Dormand-Prince's local errors at the largest
        step its controller accepts along the motion (stiff_spring.adaptive_bound)."""
        t_end = p["duration"]
        a, b = self._linear(p)
        # |x| <= scale; a velocity rounding eps/2 |v|, |v| <= |v0| + g t, is carried over at
        # most t: eps/2 (|v0| t + g t^2) <= eps scale. One rounding: at most 1.5 eps scale
        state_scale = 1.5 * self.motion_scale(p)
        if adaptive_rtol(integrator) is not None:
            return self._adaptive(p, integrator, dt, a, b, state_scale)
        steps = int(round(t_end / dt))
        k = sample_steps(steps, int(round(self.sample_dt(p) / dt)))
        x0, v0 = self._start(p)
        x, _ = discrete_solution(integrator, a, b, x0, v0, dt, k)
        ref = self.reference(p, k * dt)["position"]
        deviation = float(np.max(np.linalg.norm(x[:, :3] - ref, axis=1)))
        roundoff, roundoff_reason = roundoff_tolerance(steps, state_scale)
        return deviation + roundoff, (
            f"{integrator}'s exact discrete solution on x'' = -(b/m) v + g (b/m = "
            f"{p['drag'] / p['mass']:.3g} /s, dt = {dt:.3g} s; refsim.expected, g carried by a "
            f"constant coordinate) errs {deviation:.3g} m from the closed form at the "
            f"{len(k)} samples (max)" + roundoff_reason)

    @staticmethod
    def _linear(p):
        """(A, B) of x'' = A x + B v on (x, y, z, s), s = 1 the constant carrying g."""
        a, b = np.zeros((4, 4)), np.diag([-p["drag"] / p["mass"]] * 3 + [0.0])
        a[2, 3] = -p["g"]
        return a, b

    @staticmethod
    def _start(p):
        return np.array([0.0, 0.0, p["height"], 1.0]), np.array([p["vx0"], 0.0, p["vz0"], 0.0])

    def _adaptive(self, p, integrator, dt, a, b, state_scale, samples=4000):
        def states(t):
            ref = self.reference(p, t)
            one, zero = np.ones((len(t), 1)), np.zeros((len(t), 1))
            return np.hstack([ref["position"], one, ref["velocity"], zero])

        t = np.linspace(0.0, p["duration"], samples)
        return adaptive_bound(integrator, a, b, t, states(t), states, dt,
                              lambda e: np.linalg.norm(e[:, :3], axis=1), state_scale,
                              components=3, physical=(0, 1, 2))


CASE = FreeFall()
