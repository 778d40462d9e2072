"""Stiff spring: a mass on a linear spring to a fixed anchor, optionally damped.

m = 4 kg, default k = 4e4 N/m (w0 = 100 rad/s; variants k = 1e2 and 1e6 N/m: w0 = 5 and 500
rad/s), released from rest at displacement A = 0.1 m along x, rest length L0 = 1 m. The mass is
not 1 so that an engine forgetting to divide by it (w0 = 200 rad/s instead) fails. With
w0 = sqrt(k/m) and damping ratio zeta = c / (2 sqrt(k m)), the displacement u(t) = x(t) - L0
is, from u(0) = A, u'(0) = v0:
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

from refsim.case import Case, Param, adaptive_rtol, roundoff_tolerance, sample_steps
from refsim.expected import discrete_solution
from refsim.integrators import get_integrator
from refsim.integrators.tableaux import DOPRI5
from refsim.scene import Body, Particles, Scene, Spring, Springs

Y_SWEEP = (0.2, 0.1, 0.05, 0.025)
Y_REFERENCE = 0.05
Y_ORDER_COARSE = 0.4  # the order >= 2 methods are still on their asymptotic slope here


class StiffSpring(Case):
    name = "stiff_spring"
    description = "4 kg mass on a stiff spring to a fixed anchor, k 1e2..1e6, optional damping"
    tags = ("particle", "spring", "stiff", "exact", "stability_probe")  # refsim stress runs it
    observable, units = "displacement", "m"
    params = {
        "mass": Param(4.0, 0.0, 1e6, "kg", low_inclusive=False),
        "stiffness": Param(4e4, 0.0, 1e9, "k (N/m)", low_inclusive=False),
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
    # k = 1e2 (the soft end of the stiffness range; the default 4e4 and 1e6 bracket the
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
        return Scene(parts=(Particles.of((body,)), Springs.of((spring,))))

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

    def energy_period(self, p, settings=None):
        """Undamped, the spring conserves m u'^2/2 + k u^2/2 in any formulation (one degree of
        freedom, separable): the period 2 pi / w0 (the energy error's is half of it)."""
        return 2 * np.pi / self.omega(p) if p["zeta"] == 0 else None

    def energy_scale(self, p):
        return 0.5 * p["stiffness"] * p["amplitude"] ** 2

    def motion_scale(self, p):
        return p["amplitude"]

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        """The named method's own error: its exact discrete solution on u'' = -(k/m) u -
        (c/m) u' (refsim.expected) against the closed form, max over the samples the harness
        observes (err_max), plus round-off; dopri5_adaptive: Dormand-Prince run at the largest
        steps its controller accepts on this motion (see `adaptive_bound`). Plus an engine's
        stated damping formulation (`_damping_formulation`)."""
        t_end, w0 = self.t_end(p), self.omega(p)
        a, b = -w0 * w0, -2.0 * p["zeta"] * w0
        reference = lambda t: self.reference(p, t)["displacement"]  # noqa: E731
        if adaptive_rtol(integrator) is not None:
            return self._adaptive(p, integrator, dt, a, b)
        extra, extra_reason = self._damping_formulation(p, dt, settings)
        steps = int(round(t_end / dt))
        k = sample_steps(steps, int(round(self.sample_dt(p) / dt)))
        u, _ = discrete_solution(integrator, a, b, p["amplitude"], 0.0, dt, k)
        deviation = float(np.max(np.abs(u[:, 0] - reference(k * dt))))
        # the state x = L0 + u, |x| <= L0 + A, and v, |v| / w0 <= A: rounding both errs by at
        # most eps/2 (L0 + 2A) in u (a linear oscillation keeps it, neither grown nor damped)
        roundoff, roundoff_reason = roundoff_tolerance(
            steps, 0.5 * (p["rest_length"] + 2 * p["amplitude"]))
        return deviation + roundoff + extra, (
            f"{integrator}'s exact discrete solution on u'' = -w0^2 u - 2 zeta w0 u' "
            f"(w0 dt = {w0 * dt:.3g}, zeta = {p['zeta']:g}; refsim.expected) errs "
            f"{deviation:.3g} m from the closed form at the {len(k)} samples (max)"
            + extra_reason + roundoff_reason)

    def _damping_formulation(self, p, dt, settings, samples=4000):
        """An engine that states an exponential dashpot (settings springs.damping_method, e.g.
        pymunk: the velocity after the kick times exp(-g h), g = c / m) in place of the
        method's explicit -g v h: per step its v differs by v (e^(-g h) - 1 + g h) + h a
        (e^(-g h) - 1), at most |v| (g h)^2 / 2 + g h^2 |a|; each velocity change moves every
        later u by at most its / w0 (u^2 + (u'/w0)^2 never grows), so over the run at most
        (g^2 h / 2 TV(u) + g h TV(u')) / w0, TV the closed form's total variations."""
        springs = (settings or {}).get("springs")  # a dict, or an engine's one-line text
        method = str(springs.get("damping_method", "")) if isinstance(springs, dict) else ""
        if p["zeta"] == 0 or "exp" not in method:
            return 0.0, ""
        w0 = self.omega(p)
        rate = 2.0 * p["zeta"] * w0
        ref = self.reference(p, np.linspace(0.0, self.t_end(p), samples))
        tv_u = float(np.sum(np.abs(np.diff(ref["displacement"]))))
        tv_v = float(np.sum(np.abs(np.diff(ref["velocity"]))))
        term = (0.5 * rate * rate * dt * tv_u + rate * dt * tv_v) / w0
        return term, (f"; plus the engine's exponential dashpot in place of the method's "
                      f"explicit one: (g^2 h TV(u) / 2 + g h TV(u')) / w0 = {term:.3g} m "
                      f"(g = c / m = {rate:.3g} /s; see _damping_formulation)")

    def _adaptive(self, p, integrator, dt, a, b, samples=4000):
        """dopri5_adaptive along the closed form, state (x, 1, v, 0): x = L0 + u absolute
        (the controller's scale is rtol |x|), L0 carried by the constant coordinate; the error
        is that of x."""
        length = p["rest_length"]

        def states(t):
            ref = self.reference(p, t)
            return np.column_stack([length + ref["displacement"], np.ones_like(t),
                                    ref["velocity"], np.zeros_like(t)])

        t = np.linspace(0.0, self.t_end(p), samples)
        return adaptive_bound(integrator, [[a, -a * length], [0.0, 0.0]], [[b, 0.0], [0.0, 0.0]],
                              t, states(t), states, dt,
                              lambda e: np.abs(e[:, 0]),
                              0.5 * (length + 2 * p["amplitude"]), components=3)

    def stability(self, p):
        """`refsim stress`: y = omega dt on the undamped spring from rest, the amplitude lowered
        from 0.1 m to 1e-7 m so that the mass never reaches the anchor and the spring stays
        linear at every y searched (refsim.stress.search's docstring says why)."""
        from refsim.stress.spec import oscillator_spec
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


# -- exact discrete solutions of the named method: shared by the particle cases ---------------
def linear_jacobian(a, b):
    """J of z' = J z, z = (x, v), for x'' = A x + B v."""
    a, b = np.atleast_2d(a), np.atleast_2d(b)
    n = len(a)
    return np.block([[np.zeros((n, n)), np.eye(n)], [a, b]])


def _series(weights, a):
    """gamma_k = w . A^(k-1) 1, k = 1..s: an explicit RK method with weights w applied to a
    linear flow z' = J z is sum_k gamma_k (h J)^k (its stages are polynomials in h J)."""
    a, w = np.asarray(a, float), np.asarray(weights, float)
    out, row = [], np.ones(len(w))
    for _ in range(len(w)):
        out.append(w @ row)
        row = a @ row
    return np.array(out)


_DOPRI5_STEP = _series(DOPRI5.b, DOPRI5.a)  # the fifth-order solution
_DOPRI5_ESTIMATE = _series(np.subtract(DOPRI5.b, DOPRI5.b_low), DOPRI5.a)  # its estimate


def _polynomial(coefficients, jac, h):
    """sum_k c_k (h J)^k z-maps, one per step h (N,): shape (N, 2n, 2n)."""
    powers = [np.eye(len(jac))]
    for _ in coefficients:
        powers.append(powers[-1] @ jac)
    hk = np.asarray(h, float)[:, None] ** np.arange(1, len(coefficients) + 1)
    return np.einsum("nk,kij->nij", hk * coefficients, np.array(powers[1:]))


def adaptive_step_limits(jac, states, rtol, atol, h_top, physical, components):
    """Per state z (rows (x, v) of z' = J z, absolute positions, constants as augmented
    coordinates): the largest step <= h_top that dopri5_adaptive's controller accepts from z,
    to 1e-6 in ln h. It accepts h when its embedded estimate e = E(h) z (weights b - b_low)
    meets rms(e / (atol + rtol max(|z|, |S(h) z|))) <= 1 over the `components` entries of x
    and of v, of which only the coordinates `physical` move (refsim.integrators.adaptive);
    e grows like h^5: bisection in ln h."""
    n = jac.shape[0] // 2
    keep = np.concatenate([np.asarray(physical), n + np.asarray(physical)])

    def accepted(h):
        z1 = states + np.einsum("nij,nj->ni", _polynomial(_DOPRI5_STEP, jac, h), states)
        err = np.einsum("nij,nj->ni", _polynomial(_DOPRI5_ESTIMATE, jac, h), states)
        scale = atol + rtol * np.maximum(np.abs(states), np.abs(z1))
        return np.sum((err / scale)[:, keep] ** 2, axis=1) / (2 * components) <= 1.0

    lo = np.full(len(states), np.log(h_top) - 60.0)
    hi = np.full(len(states), np.log(h_top))
    top = accepted(np.exp(hi))
    while np.max(hi - lo) > 1e-6:
        mid = 0.5 * (lo + hi)
        ok = accepted(np.exp(mid))
        lo, hi = np.where(ok, mid, lo), np.where(ok, hi, mid)
    return np.where(top, h_top, np.exp(hi))


def adaptive_bound(integrator, a, b, t, states, later, dt, observe, state_scale,
                   components, physical=(0,)):
    """(bound, reason) of dopri5_adaptive on x'' = A x + B v (constants as augmented
    coordinates), along the exact motion: `states` (x, v) at the uniform times t spanning the
    run, `later(t)` the exact states at any times. Every step accepted from z(t) is at most
    h(t) = adaptive_step_limits(...) (and ends at the next output time at the latest): the
    run at that limit, t_j+1 = t_j + h_j, errs exactly e_j+1 = S(h_j) e_j + d_j on a linear
    system, d_j = S(h_j) z(t_j) - z(t_j+1) the local error from the exact state.
    Dormand-Prince's local error grows like h^6, so the controller's shorter steps err less;
    `observe(e)` is the observable's error of each e, max over the run. Round-off: n eps S
    for the n steps at the limit."""
    stepper = get_integrator(integrator)
    jac = linear_jacobian(a, b)
    limit = adaptive_step_limits(jac, states, stepper.rtol, stepper.atol, dt, physical,
                                 components)
    t_end, starts, steps = t[-1], [0.0], []
    outputs = dt * np.arange(1, int(round(t_end / dt)) + 1)
    k = 0
    while k < len(outputs):
        h = min(float(np.interp(starts[-1], t, limit)), outputs[k] - starts[-1])
        if starts[-1] + h >= outputs[k] * (1 - 1e-12):
            h, k = outputs[k] - starts[-1], k + 1
        steps.append(h)
        starts.append(starts[-1] + h)
    starts, steps = np.array(starts[:-1]), np.array(steps)
    step_maps = np.eye(len(jac)) + _polynomial(_DOPRI5_STEP, jac, steps)
    local = np.einsum("nij,nj->ni", step_maps, later(starts)) - later(starts + steps)
    error = np.zeros((len(steps) + 1, len(jac)))
    for j in range(len(steps)):
        error[j + 1] = step_maps[j] @ error[j] + local[j]
    deviation = float(np.max(observe(error)))
    roundoff, roundoff_reason = roundoff_tolerance(len(steps), state_scale)
    return deviation + roundoff, (
        f"dopri5_adaptive (rtol {stepper.rtol:g}, atol {stepper.atol:g}): its embedded "
        f"estimate accepts no step above h(t) = {limit.min():.3g}..{limit.max():.3g} s on "
        f"this motion (output interval {dt:.3g} s); Dormand-Prince run at that limit "
        f"({len(steps)} steps) errs {deviation:.3g} at most (its error recursion on the "
        "linear system from the exact local errors; shorter steps err less)" + roundoff_reason)


CASE = StiffSpring()
