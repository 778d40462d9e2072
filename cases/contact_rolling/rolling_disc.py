"""Disc rolling (or slipping) down an incline: constant accelerations, exact.

A body of mass m, radius r and moment I = k m r^2 about its symmetry axis (k = 1/2 a solid disc,
k = 1 a hoop: the `inertia_ratio` parameter) carries a cylinder shape (`RigidShapes`, axis along
body y = world y) and is released from rest touching an incline through the origin: a wall of
inward normal n = (sin theta, 0, cos theta), down-slope direction d = (cos theta, 0, -sin theta),
gravity -g z, Coulomb friction mu, restitution 0. The motion stays in the x-z plane (pymunk runs
it). Newton-Euler along d and about y with the friction force F up the slope and the normal force
N = m g cos theta: m a = m g sin theta - F, I alpha = F r.
- Rolling (mu >= mu_c = tan theta k / (1 + k)): a = alpha r, F = k m a, so
  a = g sin theta / (1 + k) (2/3 g sin theta for the disc, 1/2 for the hoop).
- Slipping (mu < mu_c): F = mu m g cos theta, a = g (sin theta - mu cos theta),
  alpha = mu g cos theta / (k r); the slip speed v - w r = (a - alpha r) t grows.
Observables (world y spin w_y: a point at the bottom, -r n, moves with v + w x (-r n) =
(v_d - w_y r) d, since y x n = d): `s` (m) the distance travelled along d, exact a t^2 / 2;
`residual` (m/s) v . d - w_y r, 0 when rolling, (a - alpha r) t when slipping; `spin` (rad/s)
w_y = alpha t. The compared observable is s; the spin and the residual are extra columns
(`spin_error`, `residual_max`), with `normal_gap_max`, the largest |(x - x0) . n| (a soft
contact's penetration, or a lift-off).
Source: any mechanics text (e.g. Kleppner & Kolenkow, An Introduction to Mechanics, ch. 7).
The in-house engine has no frictional rigid-body contact (the slides' rigid-body model has none):
it answers unsupported from the parts check.
"""
from __future__ import annotations

import numpy as np

from refsim.case import EPS, Param, roundoff_tolerance
from refsim.engine import ContactInfo
from refsim.scene import ContactModel, RigidBodies, Scene, Wall, Walls
from refsim.scene.rigid_shapes import RigidShapes

from refsim_cases.rigid import RigidCase

SAFETY = 2.0  # the one safety factor of the first-order bound (tolerance)
SPLIT_NOTE = ("kick-drift (v first) gives s_k = a h^2 k (k + 1) / 2, drift-kick k (k - 1) / 2: "
              "|s_k - a t^2 / 2| = a t h / 2 exactly for a constant acceleration a")


def normal(p) -> np.ndarray:
    return np.array([np.sin(p["incline"]), 0.0, np.cos(p["incline"])])


def downslope(p) -> np.ndarray:
    return np.array([np.cos(p["incline"]), 0.0, -np.sin(p["incline"])])


def critical_friction(p) -> float:
    """mu_c = tan theta k / (1 + k): the least friction that keeps the body rolling."""
    k = p["inertia_ratio"]
    return float(np.tan(p["incline"]) * k / (1.0 + k))


def rolls(p) -> bool:
    return p["friction"] >= critical_friction(p)


def accelerations(p) -> tuple[float, float]:
    """(a along d in m/s^2, alpha about +y in rad/s^2), rolling or slipping."""
    g, theta, k, r = p["g"], p["incline"], p["inertia_ratio"], p["radius"]
    if rolls(p):
        a = g * np.sin(theta) / (1.0 + k)
        return float(a), float(a / r)
    friction = p["friction"] * g * np.cos(theta)
    return float(g * np.sin(theta) - friction), float(friction / (k * r))


def body_inertia(p) -> np.ndarray:
    """diag(across, k m r^2, across): across = I_axis / 2 + m (2 h)^2 / 12 (a flat ring or disc
    by the perpendicular-axis theorem, plus its length), so A + B - C = m (2 h)^2 / 6 > 0."""
    m, r, h = p["mass"], p["radius"], p["half_length"]
    axial = p["inertia_ratio"] * m * r * r
    across = 0.5 * axial + m * (2.0 * h) ** 2 / 12.0
    return np.diag([across, axial, across])


class RollingDisc(RigidCase):
    name = "rolling_disc"
    description = ("disc (I = m r^2 / 2) or hoop (m r^2) rolling without slip down an incline, "
                   "a = g sin / (1 + I / m r^2); slipping below mu_c: a = g (sin - mu cos)")
    tags = ("rigid", "contacts", "planar", "exact")
    observable, units = "s", "m"
    params = {
        "incline": Param(np.pi / 6, 0.0, 0.5 * np.pi, "incline angle theta (rad)",
                         low_inclusive=False),
        "radius": Param(0.1, 0.0, 1e2, "r (m)", low_inclusive=False),
        "half_length": Param(0.02, 0.0, 1e2, "cylinder half length (m)", low_inclusive=False),
        "inertia_ratio": Param(0.5, 0.0, 1.0, "k = I / (m r^2)", low_inclusive=False),
        "friction": Param(0.5, 0.0, 1e2, "Coulomb friction mu"),
        "mass": Param(2.0, 0.0, 1e6, "kg (not 1: a dropped 1/m in F / m or r F / I shows)",
                      low_inclusive=False),
        "g": Param(9.81, 0.0, 1e3, "m/s^2", low_inclusive=False),
        "duration": Param(1.0, 0.0, 1e3, "s", low_inclusive=False),
    }
    # mu_c = 0.192 (disc), 0.289 (hoop) at 30 degrees: 0.5 rolls, 0.1 slips
    variants = {"disc": {}, "hoop": {"inertia_ratio": 1.0},
                "slipping": {"friction": 0.1}}
    quick_variants = ("disc",)

    def scene(self, p):
        body = RigidBodies(mass=[p["mass"]], inertia=[body_inertia(p)],
                           position=[p["radius"] * normal(p)], orientation=[(1.0, 0, 0, 0)])
        shape = RigidShapes(body=[0], shape=("cylinder",), radius=[p["radius"]],
                            half_length=[p["half_length"]])
        return Scene(parts=(body, shape, Walls.of((Wall((0.0, 0.0, 0.0), normal(p)),))),
                     contact=ContactModel(restitution=0.0, friction=p["friction"]),
                     gravity=(0.0, 0.0, -p["g"]), planar=True)

    def t_end(self, p):
        return p["duration"]

    def dts(self, p):
        """250 .. 1000 steps a second."""
        return [4e-3, 2e-3, 1e-3]

    def reference_dt(self, p):
        return 1e-3

    def observables(self, p, obs):
        x, v, w = (self.first_body(obs, name) for name in ("x", "v", "w"))
        d, x0 = downslope(p), p["radius"] * normal(p)
        return {"s": (x - x0) @ d, "residual": v @ d - w[:, 1] * p["radius"],
                "spin": w[:, 1], "normal_gap": (x - x0) @ normal(p)}

    def reference(self, p, t):
        a, alpha = accelerations(p)
        t = np.asarray(t, float)
        return {"s": 0.5 * a * t * t, "residual": (a - alpha * p["radius"]) * t,
                "spin": alpha * t, "normal_gap": np.zeros_like(t)}

    def energy(self, p, obs):
        """1/2 m |v|^2 + 1/2 w_b . I0 w_b + m g z: conserved while rolling (static friction
        does no work); None when slipping (friction dissipates)."""
        if not rolls(p):
            return None
        v, x = self.first_body(obs, "v"), self.first_body(obs, "x")
        w_body = self.body_omega(obs)
        spin = 0.5 * np.sum(w_body * (np.diag(body_inertia(p)) * w_body), axis=-1)
        return 0.5 * p["mass"] * np.sum(v * v, axis=-1) + spin + p["mass"] * p["g"] * x[:, 2]

    def energy_scale(self, p):
        return p["mass"] * p["g"] * np.sin(p["incline"]) * self.motion_scale(p)

    def motion_scale(self, p):
        """s at the end: a t^2 / 2 (m)."""
        return 0.5 * accelerations(p)[0] * p["duration"] ** 2

    def extra_metrics(self, p, obs, observed, reference):
        return {"residual_max": float(np.max(np.abs(observed["residual"]
                                                    - reference["residual"]))),
                "spin_error": float(np.max(np.abs(observed["spin"] - reference["spin"]))),
                "normal_gap_max": float(np.max(np.abs(observed["normal_gap"])))}

    # -- tolerance ------------------------------------------------------------------------------
    def compliance_bound(self, p, settings) -> tuple[float, str]:
        """A soft contact of duration T_c = pi / sqrt(K) sinks by at most
        delta = f g cos theta / K (f: the engine's sink factor, ContactInfo; 1e-4 for MuJoCo's
        impedance 0.9999); rolling on radii within [r - delta, r] (torque arm and kinematic
        radius) changes a = g sin / (1 + I / (m rho_t rho_k)) by a relative
        |d ln a| <= k / (1 + k) 2 delta / r, so s by that times a t^2 / 2. Soft friction rows
        (MuJoCo's) let the contact creep at v_c = f a0_t / B, a0_t = g sin theta (the contact
        point's unconstrained acceleration), B = 2 pi / T_c; a slip set up by an impulse
        J at the contact changes v by J / m and v_c = J (1/m + r^2 / I), so the centre gains
        at most k / (1 + k) v_c (k = I / (m r^2)), kept over the run. Slipping: the friction
        force mu N and a do not depend on the radius; alpha only through rho_t."""
        info = ContactInfo.of(settings)
        if not info.soft or info.duration_s <= 0:
            return 0.0, ""
        k, f, tc = p["inertia_ratio"], info.sink_factor, info.duration_s
        delta = f * p["g"] * np.cos(p["incline"]) * (tc / np.pi) ** 2
        rel = k / (1.0 + k) * 2.0 * delta / p["radius"] if rolls(p) else 0.0
        bound = rel * self.motion_scale(p)
        why = (f"; plus soft contact: sinks delta <= f g cos theta (T_c / pi)^2 = {delta:.3g} "
               f"m (T_c = {tc:.3g} s, sink factor f = {f:.3g}), a changed by <= k / (1 + k) "
               f"2 delta / r = {rel:.3g} relative (rolling radius r - delta): {bound:.3g} m")
        if info.soft_friction and rolls(p):
            creep = k / (1.0 + k) * f * p["g"] * np.sin(p["incline"]) * tc / (2 * np.pi)
            bound += creep * p["duration"]
            why += (f"; plus the soft friction's creep: the contact slips at v_c = f g sin "
                    f"theta / B (B = 2 pi / T_c), the centre gains k / (1 + k) v_c = "
                    f"{creep:.3g} m/s, over the run {creep * p['duration']:.3g} m")
        return bound, why

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        """Constant accelerations: a first-order split step errs by a t h / 2 exactly
        (SPLIT_NOTE), taken with the safety factor SAFETY for the contact's onset (the first
        steps' impulse or a soft contact's settling, not modelled); a method of order >= 2
        integrates a constant acceleration exactly. `order` is the NAMED method's. Plus the
        soft contact's radius change and round-off."""
        a, t = accelerations(p)[0], p["duration"]
        split = SAFETY * 0.5 * a * t * dt if order < 2 else 0.0
        reason = (f"order {order:g}: " + (
            SPLIT_NOTE + f", times the safety factor {SAFETY:g} for the contact's onset (the "
            f"first steps' impulse or a soft contact's settling): {split:.3g} m"
            if order < 2 else "a constant acceleration is integrated exactly by a method of "
            "order >= 2"))
        soft, soft_reason = self.compliance_bound(p, settings)
        scale = p["radius"] + self.motion_scale(p) + a * t * dt
        roundoff, roundoff_reason = roundoff_tolerance(round(t / dt), scale)
        return split + soft + roundoff, reason + soft_reason + roundoff_reason

    def error_floor(self, p):
        return 1e3 * EPS * (p["radius"] + self.motion_scale(p))


CASE = RollingDisc()


def observed_errors(engine, p, dt, integrator, order=None):
    """Run the case on `engine` for its duration, observing every step: (max |observed -
    reference| of each reference observable, the case's tolerance at `order`, its reason).
    The engines' rolling tests share it; AssertionError if the engine reports a failure."""
    sim = engine.build(CASE.scene(p), dt, integrator)
    frames, times = {k: [] for k in ("x", "v", "w", "q")}, []
    for _ in range(round(p["duration"] / dt)):
        sim.step(1)
        obs = sim.observe()
        times.append(obs["t"])
        for key, frame in frames.items():
            frame.append(np.asarray(obs[key]))
    assert sim.failure is None, sim.failure
    observed = CASE.observables(p, {k: np.array(v) for k, v in frames.items()})
    reference = CASE.reference(p, np.array(times))
    err = {k: float(np.max(np.abs(observed[k] - reference[k]))) for k in reference}
    if order is None:  # the named method's order where it names a refsim method
        order = _named_order(integrator, sim.settings())
    tol, reason = CASE.tolerance(p, integrator, order, dt, settings=sim.settings())
    sim.close()
    return err, tol, reason


def _named_order(integrator, settings) -> float:
    """The order of the refsim method `integrator` names, else the engine's declared one."""
    from refsim.engine import IntegratorInfo
    from refsim.integrators import get_integrator
    try:
        return get_integrator(integrator).order
    except ValueError:
        described = IntegratorInfo.of(settings)
        return described.order if described is not None else 1
