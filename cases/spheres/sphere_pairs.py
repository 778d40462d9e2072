"""Sphere pairs: two spheres meet head-on (impact parameter b = 0) or obliquely, with
restitution e and Coulomb friction mu; exact post-impact velocities and spins.

No gravity. Radius r, masses m1 and m2 = ratio * m1. Sphere 1 at (-0.5, 0, 0) moving at
(+v, 0, 0) (spinning at `spin` about y), sphere 2 at (0.5, 0, b) moving at (-v, 0, 0). They
touch at t_c = (1 - sqrt(4 r^2 - b^2)) / (2 v) with unit normal n = (sqrt(4 r^2 - b^2), 0, b)
/ (2 r). Exact outcome of a frictionless impact with restitution e (Newton's law along n):
j = (1 + e) m1 m2 / (m1 + m2) ((v1 - v2) . n), v1' = v1 - j/m1 n, v2' = v2 + j/m2 n.
Head-on with v1 = 1, v2 = -1: equal masses give (-e, e); 1:3 gives (-2, 0) at e = 1 and
(-1.25, -0.25) at e = 0.5 (docs/engine_notes.md#exact-head-on-collision-outcomes). With
friction, the tangential impulse follows the Coulomb stick/slide law for one impact of
Guendelman, Bridson & Fedkiw, "Nonconvex rigid bodies with stacking", SIGGRAPH 2003.

Observables and metrics: see `refsim_cases.spheres._impact` (`velocity` in m/s compared after the
impact, `position_err`, `momentum_drift`, `penetration_max`, `energy_drift` against the exact
kinetic energy). Bounds (`tolerance`): an impulse contact gives the exact outcome to
round-off; discrete detection on an oblique impact finds the pair up to a step late, its centre
line turned by |u_t| dt / 2r, which moves the outcome by at most (1 + e) mu |u| (1 + mu_f)
sqrt(1/m1^2 + 1/m2^2) times that angle; a soft (spring-damper) contact errs by the engine's
stated restitution calibration residual times mu |u_n| sqrt(1/m1^2 + 1/m2^2), plus the same
turn over its stated contact duration and one step.
"""
from __future__ import annotations

import numpy as np

from refsim_cases.spheres._impact import SPHERE_PARAMS, SingleImpactCase
from refsim.case import Param
from refsim.engine import ContactInfo


class SpherePairs(SingleImpactCase):
    name = "sphere_pairs"
    description = "two spheres meeting head-on or obliquely, restitution and friction; exact"
    tags = ("contacts", "rigid", "exact")
    params = {
        **SPHERE_PARAMS,
        "ratio": Param(1.0, 0.0, 1e6, "m2 / m1", low_inclusive=False),
        "impact": Param(0.0, 0.0, 10.0, "impact parameter b (m), < 2 r"),
        "spin": Param(0.0, -1e4, 1e4, "sphere 1 angular velocity about y (rad/s)"),
    }
    variants = {
        "head_on": {},
        "head_on_e0.5": {"restitution": 0.5},
        "head_on_1to3": {"ratio": 3.0},
        "head_on_1to3_e0.5": {"ratio": 3.0, "restitution": 0.5},
        "oblique": {"impact": 0.1},
        "oblique_friction": {"impact": 0.1, "friction": 0.3, "spin": 20.0},
    }
    quick_variants = ("head_on", "oblique")
    # the 1:3 pair at e = 0.5 combines what head_on_e0.5 and head_on_1to3 test apart: it runs by
    # name, so the default run stays under 5 minutes with the rigid cases
    default_variants = ("head_on", "head_on_e0.5", "head_on_1to3", "oblique", "oblique_friction")

    def validate(self, overrides=None):
        p = super().validate(overrides)
        if p["impact"] >= 2 * p["radius"]:
            raise ValueError(f"{self.name}.impact must be in [0, 2 radius) = [0, "
                             f"{2 * p['radius']:g}), got {p['impact']}")
        return p

    def initial_state(self, p):
        v = p["speed"]
        x = np.array([[-0.5, 0.0, 0.0], [0.5, 0.0, p["impact"]]])
        velocity = np.array([[v, 0.0, 0.0], [-v, 0.0, 0.0]])
        m = np.array([p["mass"], p["mass"] * p["ratio"]])
        w = np.zeros_like(x)
        w[0, 1] = p["spin"]
        return x, velocity, m, w

    def contact_time(self, p):
        r = p["radius"]
        return (1.0 - np.sqrt(4 * r * r - p["impact"] ** 2)) / (2 * p["speed"])

    def outcome(self, p):
        """Exact post-impact (velocities, angular velocities), each (2, 3): Newton restitution
        along n; with friction, the Coulomb stick/slide impulse of Guendelman et al. 2003."""
        x0, v0, m, w0 = self.initial_state(p)
        v1, w1 = v0.copy(), w0.copy()
        r, b, e, mu = p["radius"], p["impact"], p["restitution"], p["friction"]
        n = np.array([np.sqrt(4 * r * r - b * b), 0.0, b]) / (2 * r)
        arm1, arm2 = r * n, -r * n  # centre -> contact point
        u = (v0[1] + np.cross(w0[1], arm2)) - (v0[0] + np.cross(w0[0], arm1))
        un = u @ n
        pn = -(1 + e) * un / (1 / m[0] + 1 / m[1])
        impulse = pn * n
        ut = u - un * n
        slide = np.linalg.norm(ut)
        inertia = 0.4 * m * r * r  # 2/5 m r^2, this rounding kept for bit-identical outcomes
        if mu > 0 and slide > 0:
            k_t = 1 / m[0] + 1 / m[1] + r * r / inertia[0] + r * r / inertia[1]
            impulse = impulse - min(slide / k_t, mu * pn) * ut / slide
        v1[0] -= impulse / m[0]
        v1[1] += impulse / m[1]
        w1[0] -= np.cross(arm1, impulse) / inertia[0]
        w1[1] += np.cross(arm2, impulse) / inertia[1]
        return v1, w1

    def impact_kinematics(self, p):
        """(mu = m1 m2 / (m1 + m2), |u_n|, |u| at the contact point, |u_t| of the centres,
        sqrt(1/m1^2 + 1/m2^2)) at first touch: what the outcome's sensitivities are made of."""
        _, v0, m, w0 = self.initial_state(p)
        r, b = p["radius"], p["impact"]
        n = np.array([np.sqrt(4 * r * r - b * b), 0.0, b]) / (2 * r)
        centres = v0[1] - v0[0]
        u = centres + np.cross(w0[1], -r * n) - np.cross(w0[0], r * n)
        tangential = float(np.linalg.norm(centres - (centres @ n) * n))
        return (m[0] * m[1] / (m[0] + m[1]), abs(float(u @ n)), float(np.linalg.norm(u)),
                tangential, float(np.hypot(1 / m[0], 1 / m[1])))

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        """Impulse contact: the exact outcome to round-off, plus, for discrete detection on an
        oblique impact, the turn of the normal over a late step. Soft contact: the engine's
        stated restitution calibration residual, plus the normal's turn over the contact's
        stated duration (and the late step). Reasons state the derivations."""
        contact = ContactInfo.of(settings)
        v, e, r, mu_f = p["speed"], p["restitution"], p["radius"], p["friction"]
        mu, u_n, u, u_t, spread = self.impact_kinematics(p)
        tol, reason = 1e-9 * v, "round-off 1e-9 v"
        # d[(u.n) n]/d(theta) has magnitude <= |u|: turning the normal by theta moves the
        # impulse (1 + e) mu (u.n) n by (1 + e) mu |u| theta, the friction impulse (<= mu_f
        # times it) at most as much again; each sphere's velocity by that over its mass
        turn_gain = (1 + e) * mu * u * (1 + mu_f) * spread
        if contact.soft:
            if contact.restitution_residual <= 0.0:
                return 0.1 * (1 + e) * v, (
                    "soft (spring-damper) contact stating no calibration residual: the "
                    "restitution obtained from a damping ratio is approximate, +9 % to -10 % "
                    "(docs/engine_notes.md#mujoco-no-restitution-parameter), on a velocity "
                    "change (1+e) v")
            de = contact.restitution_residual
            restitution = de * mu * u_n * spread
            theta = u_t * (contact.duration_s + dt) / (2 * r)
            tol += restitution + turn_gain * theta
            return tol, (
                f"soft (spring-damper) contact, the engine's stated parameters: its calibrated "
                f"restitution is within residual_max = {de:.3g} of e at every contact onset "
                f"(the spring-damper is linear in acceleration space: e depends on neither "
                f"mass nor speed), so the normal impulse is off by at most de mu |u_n| and the "
                f"velocities by de mu |u_n| sqrt(1/m1^2 + 1/m2^2) = {restitution:.3g}; plus the "
                f"centre line's turn while the impulse is delivered, theta = |u_t| (T_c + dt) "
                f"/ 2r = {theta:.3g} rad (T_c = {contact.duration_s:.3g} s the stated contact "
                f"duration, one step of late detection), moving the outcome by at most "
                f"(1 + e) mu |u| (1 + mu_f) sqrt(1/m1^2 + 1/m2^2) theta = "
                f"{turn_gain * theta:.3g}; plus {reason}")
        reason = ("impulse contact with Newton's restitution law (and Coulomb stick/slide): "
                  "the exact outcome to " + reason)
        if contact.detection == "discrete" and p["impact"] > 0:
            theta = u_t * dt / (2 * r)
            tol += turn_gain * theta
            reason += (f"; plus discrete detection: the pair is found up to one step late, "
                       f"its centre line turned by up to |u_t| dt / 2r = {theta:.3g} rad, which "
                       f"moves the outcome by at most (1 + e) mu |u| (1 + mu_f) "
                       f"sqrt(1/m1^2 + 1/m2^2) theta = {turn_gain * theta:.3g}")
        return tol, reason

CASE = SpherePairs()
