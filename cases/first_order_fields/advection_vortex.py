"""Advection of massless particles in a rigid vortex (slide 003: "advection of massless
particles ... millions to billions of particles ... pleasantly parallel";
docs/models.md#fields-vortex-radius-per-step).

p' = Omega x (p - c): every particle turns about the axis through c along Omega at |Omega|
rad/s, keeping its distance from the axis. Compared observable `x_error`: max over particles of
|p - p(t)| (m) against the continuum rotation. Exact discrete oracle, y = |Omega| h: in the
plane normal to Omega a step of a method with stability function R multiplies the complex
coordinate by R(i y), so the distance from the axis grows by exactly |R(i y)| a step and the
step turns by arg R(i y):
- forward Euler: sqrt(1 + y^2);
- midpoint, Heun (every two-stage second-order tableau): sqrt(1 + y^4/4);
- RK4: sqrt(1 - y^6/72 + y^8/576);
- implicit Euler: 1/sqrt(1 + y^2).
(|R(iy)|^2 = |1 + iy - y^2/2|^2 = 1 + y^4/4; for RK4 (1 - y^2/2 + y^4/24)^2 + (y - y^3/6)^2
= 1 - y^6/72 + y^8/576.) The full discrete position c + R(h M)^k (p_0 - c) (M = [Omega]_x)
is the tolerance's exact part (`_affine.AffineFieldCase`). The 'energy' is the mean distance
from the axis, conserved by the flow: its drift column shows |R(iy)|^k - 1.
Orders against the continuum: 1, 2, 2, 4 (and 1 for implicit Euler).
"""
from __future__ import annotations

import numpy as np

from refsim.case import Param
from refsim.models.advection import axial_radius
from refsim.scene.velocity_field import VelocityField

from ._affine import AffineFieldCase

AXIS = np.array([1.0, 2.0, 2.0]) / 3.0  # the vortex axis (unit), off every coordinate axis
CENTRE = (0.3, -0.2, 0.1)  # m


class AdvectionVortex(AffineFieldCase):
    name = "advection_vortex"
    description = ("massless particles in a rigid vortex (first order p' = Omega x (p - c)): "
                   "each RK method's exact radius growth |R(i Omega h)| per step")
    tags = ("particle_fields", "first_order", "advection", "exact")
    params = {
        "omega": Param(1.3, 0.0, 1e3, "|Omega| (rad/s); not 1, so that an engine dropping "
                       "it fails", low_inclusive=False),
        "particles": Param(200, 1, 1e7, "tracer count (a cube of side 2 m about c, seeded)"),
        "revolutions": Param(1.0, 0.0, 1e3, "run length in turns", low_inclusive=False),
        "seed": Param(14, 0, 2 ** 31, "start positions' random seed"),
    }
    variants = {"default": {}, "many": {"particles": 10000},
                "long": {"revolutions": 20.0, "particles": 100}}
    default_variants = ("default",)

    def field(self, p):
        return VelocityField("rigid_vortex", centre=CENTRE, omega=tuple(p["omega"] * AXIS))

    def start(self, p):
        rng = np.random.default_rng(int(p["seed"]))
        return np.array(CENTRE) + rng.uniform(-1.0, 1.0, size=(int(p["particles"]), 3))

    def t_end(self, p):
        return 2.0 * np.pi * p["revolutions"] / p["omega"]

    def dts(self, p):
        """y = |Omega| h = 0.1, 0.05, 0.025."""
        return [0.1 / p["omega"], 0.05 / p["omega"], 0.025 / p["omega"]]

    def order_dts(self, p):
        """y = 0.01: the sweep spans a decade (accuracy pass only)."""
        return [0.01 / p["omega"]]

    def reference_dt(self, p):
        return 0.025 / p["omega"]

    def energy(self, p, obs):
        """Mean distance from the vortex axis (m), conserved by the flow."""
        return np.mean(axial_radius(np.asarray(obs["x"], float), np.array(CENTRE), AXIS),
                       axis=-1)

    def energy_scale(self, p):
        return float(np.mean(axial_radius(self.start(p), np.array(CENTRE), AXIS)))

    def extra_metrics(self, p, obs, observed, reference):
        """radius_growth_rate (1/s): ln(r(t)/r(0)) / t at the end, mean over particles;
        exactly ln|R(i y)| / h for a method of stability function R."""
        x, t = np.asarray(obs["x"], float), np.asarray(obs["t"], float)
        radius = axial_radius(x[[0, -1]], np.array(CENTRE), AXIS)
        return {"radius_growth_rate": float(np.mean(np.log(radius[1] / radius[0])) / t[-1])}


CASE = AdvectionVortex()
