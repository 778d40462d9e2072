"""Compound pendulum: a thin uniform rod pivoted at one end, swinging in the x-z plane.

Rod of mass m and length L along its body axis 3; about its centre of mass I = m L^2 / 12 on the
two axes across it and m (AXIAL_RADIUS L)^2 / 2 along it (a rod of radius L/100: the axial
moment never enters, since w stays along world y, across the rod). Its top end (body point
(0, 0, L/2)) is pivoted at the origin (`RigidPivots`, a ball joint: w stays along y, so it is a
hinge about world y); gravity -z; released from rest at theta0 (the rod turned by -theta0 about
world y, the centre of mass at (L/2 sin theta0, 0, -L/2 cos theta0)).
About the pivot I_p = m L^2 / 3, the torque m g (L/2) sin theta: theta'' = -w0^2 sin theta with
w0^2 = m g (L/2) / (m L^2 / 3) = 3 g / (2 L): the pendulum's Jacobi elliptic solution
(`cases.particles.pendulum.exact_pendulum`) at that w0. The point-mass pendulum of the same
length has w0^2 = g / L: small-swing periods 2 pi sqrt(2 L / (3 g)) (rod) and 2 pi sqrt(L / g)
(point mass), the rod's shorter by sqrt(2/3) (its mass sits nearer the pivot: the two inertias
m L^2 / 3 and m L^2 against torque arms L / 2 and L). Compared observable `theta` (rad), the
angle of the rod's centre of mass from the downward vertical (atan2(x, -z)).
"""
from __future__ import annotations

import numpy as np

from cases.particles.pendulum import exact_pendulum, period_sensitivity
from refsim.case import (
    ADAPTIVE_REASON,
    Param,
    adaptive_rtol,
    is_symplectic,
    order_tolerance,
    roundoff_tolerance,
)
from refsim.scene import RigidBodies, Scene
from refsim.scene.pivots import RigidPivots

from . import RigidCase, rotation_quaternion
from .heavy_top import PRINTED_NOTE, effective_order

AXIAL_RADIUS = 1e-2  # rod radius / L: axial moment m (L/100)^2 / 2


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
        "length": Param(1.0, 0.0, 1e3, "rod length L (m)", low_inclusive=False),
        "mass": Param(1.0, 0.0, 1e6, "kg", low_inclusive=False),
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
        return Scene(rigid=rod, extra=(pivot,), gravity=(0.0, 0.0, -p["g"]), planar=True)

    def t_end(self, p):
        return p["duration"]

    def dts(self, p):
        """w0 dt = 0.031 .. 0.008 (w0 = 3.84 rad/s at L = 1 m)."""
        return [8e-3, 4e-3, 2e-3]

    def order_dts(self, p):
        """Coarser steps for the order fit only: w0 dt up to 0.12."""
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
        theta0, w_t = p["theta0"], rod_rate(p) * p["duration"]
        rtol = adaptive_rtol(integrator)
        if rtol is not None:
            return 10 * rtol * theta0 * w_t, ADAPTIVE_REASON
        printed = engine_variant == "matrix_printed"
        order = effective_order(order, engine_variant)
        symplectic = is_symplectic(settings) and not printed
        tol = order_tolerance(theta0, w_t, rod_rate(p) * dt, order, symplectic)
        growth = 1.0 + period_sensitivity(theta0) * w_t
        if symplectic:
            reason = (f"order {order}, symplectic (as the engine declares): theta0 ((w0 dt)^p + "
                      "w0 t (w0 dt)^q), q = 2 ceil(p/2) (see order_tolerance)")
        else:
            tol *= growth
            reason = (f"order {order}: theta0 expm1(w0 t (w0 dt)^p) (see order_tolerance), times "
                      f"1 + kappa w0 t = {growth:.3g}: an energy error changes the period by "
                      "kappa = dlnT/dlnE of it (cases.particles.pendulum.period_sensitivity)")
        roundoff, roundoff_reason = roundoff_tolerance(round(p["duration"] / dt),
                                                       1.0 + theta0)
        return tol + roundoff * growth, reason + roundoff_reason + (
            f", times 1 + kappa w0 t = {growth:.3g}") + (PRINTED_NOTE if printed else "")


CASE = CompoundPendulum()
