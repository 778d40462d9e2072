"""Compound pendulum: a thin uniform rod pivoted at one end, swinging in the x-z plane.

Rod of mass m and length L along its body axis 3; about its centre of mass I = m L^2 / 12 on the
two axes across it and m (AXIAL_RADIUS L)^2 / 2 along it (a rod of radius L/100: the axial
moment never enters, since w stays along world y, across the rod). Its top end (body point
(0, 0, L/2)) is pivoted at the origin (`RigidPivots`, a ball joint: w stays along y, so it is a
hinge about world y); gravity -z; released from rest at theta0 (the rod turned by -theta0 about
world y, the centre of mass at (L/2 sin theta0, 0, -L/2 cos theta0)).
About the pivot I_p = m L^2 / 3, the torque m g (L/2) sin theta: theta'' = -w0^2 sin theta with
w0^2 = m g (L/2) / (m L^2 / 3) = 3 g / (2 L): the pendulum's Jacobi elliptic solution
(`refsim_cases.particles.pendulum.exact_pendulum`) at that w0. The point-mass pendulum of the same
length has w0^2 = g / L: small-swing periods 2 pi sqrt(2 L / (3 g)) (rod) and 2 pi sqrt(L / g)
(point mass), the rod's shorter by sqrt(2/3) (its mass sits nearer the pivot: the two inertias
m L^2 / 3 and m L^2 against torque arms L / 2 and L). Compared observable `theta` (rad), the
angle of the rod's centre of mass from the downward vertical (atan2(x, -z)).
"""
from __future__ import annotations

import numpy as np

from refsim_cases.particles.pendulum import exact_pendulum, period_sensitivity
from refsim.case import ADAPTIVE_REASON, Param, adaptive_rtol, roundoff_tolerance
from refsim.scene import RigidBodies, Scene
from refsim.scene.pivots import RigidPivots

from refsim_cases.rigid import RigidCase, rotation_quaternion
from refsim_cases.rigid._bounds import PRINTED_REASON, chart_error, linear_swing_error, mode_error

AXIAL_RADIUS = 1e-2  # rod radius / L: axial moment m (L/100)^2 / 2
SAFETY = 2.0  # the one safety factor of the bound (tolerance)


def rod_inertia(p) -> np.ndarray:
    """Body-frame inertia about the centre of mass, rod along axis 3."""
    across = p["mass"] * p["length"] ** 2 / 12.0
    along = 0.5 * p["mass"] * (AXIAL_RADIUS * p["length"]) ** 2
    return np.diag([across, across, along])


def rod_rate(p) -> float:
    """w0 = sqrt(3 g / (2 L)) (rad/s)."""
    return float(np.sqrt(1.5 * p["g"] / p["length"]))


def small_swing_periods(p) -> tuple[float, float]:
    """(2 pi sqrt(2 L / 3 g), 2 pi sqrt(L / g)): the rod's and the point mass's."""
    return 2 * np.pi / rod_rate(p), 2 * np.pi * np.sqrt(p["length"] / p["g"])


class CompoundPendulum(RigidCase):
    name = "compound_pendulum"
    description = ("thin rod pivoted at one end, released from rest at theta0: Jacobi-elliptic "
                   "exact with w0^2 = 3 g / (2 L) (point mass: g / L; periods 2 pi sqrt(2L/3g) "
                   "vs 2 pi sqrt(L/g) when small)")
    tags = ("rigid", "pivot", "planar", "exact")
    observable, units = "theta", "rad"
    params = {
        "theta0": Param(1.0, 0.0, np.pi, "release angle (rad)", low_inclusive=False),
        "length": Param(0.8, 0.0, 1e3, "rod length L (m)", low_inclusive=False),
        "mass": Param(2.5, 0.0, 1e6, "kg (not 1: an engine dropping m from I = m L^2 / 3 or "
                      "from the torque fails)", low_inclusive=False),
        "g": Param(9.81, 0.0, 1e3, "m/s^2", low_inclusive=False),
        "duration": Param(4.0, 0.0, 1e4, "s", low_inclusive=False),
    }
    variants = {"default": {}, "small": {"theta0": 0.05}}
    quick_variants = ("default",)
    # the small swing (the two inertias' periods) runs by name: the default run stays < 5 min
    default_variants = ("default",)

    def scene(self, p):
        half = 0.5 * p["length"]
        q0 = rotation_quaternion(np.array([0.0, -p["theta0"], 0.0]))
        com = half * np.array([np.sin(p["theta0"]), 0.0, -np.cos(p["theta0"])])
        rod = RigidBodies(mass=[p["mass"]], inertia=[rod_inertia(p)], position=[com],
                          orientation=[q0])
        pivot = RigidPivots(body=[0], body_point=[(0.0, 0.0, half)], anchor=[(0.0, 0.0, 0.0)])
        return Scene(parts=(rod, pivot), gravity=(0.0, 0.0, -p["g"]), planar=True)

    def t_end(self, p):
        return p["duration"]

    def dts(self, p):
        """w0 dt = 0.034 .. 0.0086 (w0 = 4.29 rad/s at L = 0.8 m)."""
        return [8e-3, 4e-3, 2e-3]

    def order_dts(self, p):
        """Coarser steps for the order fit only: w0 dt up to 0.14."""
        return [3.2e-2, 1.6e-2]

    def reference_dt(self, p):
        return 2e-3

    def observables(self, p, obs):
        x, v = self.first_body(obs, "x"), self.first_body(obs, "v")
        return {"theta": np.arctan2(x[:, 0], -x[:, 2]),
                "theta_dot": (x[:, 2] * v[:, 0] - x[:, 0] * v[:, 2])
                / (x[:, 0] ** 2 + x[:, 2] ** 2)}

    def reference(self, p, t):
        theta, theta_dot = exact_pendulum(p["theta0"], rod_rate(p), t)
        return {"theta": theta, "theta_dot": theta_dot}

    def energy(self, p, obs):
        """1/2 m |v|^2 + 1/2 w_b . I0 w_b + m g z."""
        v, x = self.first_body(obs, "v"), self.first_body(obs, "x")
        w_body = self.body_omega(obs)
        spin = 0.5 * np.sum(w_body * (np.diag(rod_inertia(p)) * w_body), axis=-1)
        return 0.5 * p["mass"] * np.sum(v * v, axis=-1) + spin + p["mass"] * p["g"] * x[:, 2]

    def energy_scale(self, p):
        return 0.5 * p["mass"] * p["g"] * p["length"]

    def motion_scale(self, p):
        return p["theta0"]

    def extra_metrics(self, p, obs, observed, reference):
        return self.orientation_metrics(obs)

    def error_floor(self, p):
        """Round-off, 1e-11 theta0 per second of the run (as the point-mass pendulum's)."""
        return 1e-11 * p["theta0"] * p["duration"]

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        """SAFETY x (the exact discrete solution's error of the named method on the linearised
        swing theta'' = -w0^2 theta from theta0 + theta0 n |alpha(w0 h)| kappa w0 t, the
        energy error's phase shift) + the printed matrix's stretch + round-off (1 + kappa w0
        t). The rod turns about a principal axis: w x I w = 0, no gyroscopic term."""
        theta0, w0 = p["theta0"], rod_rate(p)
        w_t = w0 * p["duration"]
        kappa = period_sensitivity(theta0)
        growth = 1.0 + kappa * w_t
        rtol = adaptive_rtol(integrator)
        if rtol is not None:
            return 10 * rtol * theta0 * w_t * growth, ADAPTIVE_REASON + (
                f", times 1 + kappa w0 t = {growth:.3g}")
        steps = int(round(p["duration"] / dt))
        printed = engine_variant == "matrix_printed"
        swing = linear_swing_error(integrator, theta0, w0, dt, steps)
        # the energy error's phase shift: the amplitude error grows linearly to n |alpha|,
        # its energy error 2 n |alpha| changes the period by kappa of it: kappa w0 t n |alpha|
        gain = 2.0 * kappa * w_t
        speed = 2.0 * w0 * np.sin(0.5 * min(theta0, np.pi))  # max |theta'| of the swing
        # the printed stretch s scales I_p by s^2 and the torque by s: w0 ~ s^(-1/2), a phase
        # error w0 t (s - 1) / 2, (s - 1) growing linearly: gain w0 t / 2 on top of kappa's
        stretch_gain = gain + 0.5 * w_t
        drift = mode_error(integrator, [(theta0, w0)], dt, steps, gain,
                           printed=(theta0, speed, stretch_gain) if printed else None)
        phase_only = mode_error(integrator, [(theta0, w0)], dt, steps, 0.0)
        drift = max(drift - phase_only, 0.0)  # the energy terms only: linear error has the rest
        # the chart's turning error: theta is the turning itself (sensitivity 1)
        chart = chart_error(integrator, engine_variant or "quat_exp", 1.0, speed, dt, steps)
        roundoff, roundoff_reason = roundoff_tolerance(steps, 1.0 + theta0)
        reason = (f"order {order}: {SAFETY:g} x (the exact discrete solution's error of the "
                  f"method on the linearised swing theta'' = -w0^2 theta from theta0 = "
                  f"{theta0:.3g} rad, w0 = {w0:.3g} rad/s, n = {steps} steps: {swing:.3g} rad "
                  "(refsim.expected.discrete_solution; shape, phase and amplitude), plus theta0 "
                  "n |alpha(w0 h)| kappa w0 t: an energy error 2 n |alpha| changes the period "
                  f"by kappa = dlnT/dlnE = {kappa:.3g} of it, half of it over the run; plus "
                  "the orientation chart's turning error n |step angle - y| at y = max|theta'| "
                  f"h (_bounds.chart_step_angle, 0 for the exponential map): {chart:.3g} rad); "
                  f"safety factor {SAFETY:g}")
        if printed:
            reason += PRINTED_REASON.format(rate=speed) + (
                f", its phase gain 2 kappa w0 t + w0 t / 2 = {stretch_gain:.3g} (I_p grows as "
                "s^2 and the torque as s: w0 ~ s^(-1/2))")
        return SAFETY * (swing + drift + chart) + roundoff * growth, reason + roundoff_reason + (
            f", times 1 + kappa w0 t = {growth:.3g}")


CASE = CompoundPendulum()
