"""Gradient descent on a quadratic (slide 003: p_{i+1} = p_i - h grad E(p_i), which tends to
dp/dt = -grad E(p) as h -> 0), as first-order particle dynamics.

E(p) = 1/2 sum_k lambda_k (p_k - c_k)^2, u = -grad E = -diag(lambda) (p - c). Per axis the flow
decays as exp(-lambda_k t); explicit Euler (the slide's update) contracts by exactly 1 - h
lambda_k a step, stable iff |1 - h lambda_k| < 1, i.e. h < 2 / lambda_k; every method of
stability function R by R(-h lambda_k) (RK4 stable for h lambda < 2.785, midpoint and Heun for
h lambda < 2); implicit Euler by 1 / (1 + h lambda_k), stable for every h. Compared observable
`x_error`: max over particles of |p - p(t)| (m) against the flow; the tolerance is the exact
discrete deviation c + R(-h Lambda)^k (p_0 - c) - p(t_k) plus round-off (`_affine`). The
'energy' is the mean of E over particles, which the flow decreases (the drift column is how
much of it was removed). The variant `unstable` runs h lambda_max = 2.5 > 2: explicit Euler,
midpoint and Heun diverge (|R| > 1), RK4 and implicit Euler converge.
"""
from __future__ import annotations

import numpy as np

from refsim.case import Param
from refsim.scene.velocity_field import VelocityField

from ._affine import AffineFieldCase

CENTRE = (0.5, -0.25, 1.0)  # m


class GradientDescent(AffineFieldCase):
    name = "gradient_descent"
    description = ("gradient descent on a quadratic, p' = -grad E: exact contraction 1 - h "
                   "lambda per step (forward Euler), R(-h lambda) for every method")
    tags = ("particle_fields", "first_order", "gradient_descent", "exact")
    params = {
        "lambda_max": Param(10.0, 0.0, 1e4, "largest rate lambda_3 (1/s); lambda = "
                            "(0.1, 0.4, 1) lambda_max", low_inclusive=False),
        "particles": Param(20, 1, 1e7, "start points (a cube of side 2 m about c, seeded)"),
        "duration": Param(2.0, 0.0, 1e4, "s, in units of 10 / lambda_max", low_inclusive=False),
        "h_scale": Param(1.0, 0.0, 100.0, "dt multiplier (unstable variant: 2.5/0.1)",
                         low_inclusive=False),
        "seed": Param(14, 0, 2 ** 31, "start positions' random seed"),
    }
    variants = {"default": {}, "unstable": {"h_scale": 25.0, "duration": 20.0}}
    default_variants = ("default",)

    def rates(self, p):
        return tuple(p["lambda_max"] * np.array([0.1, 0.4, 1.0]))

    def field(self, p):
        return VelocityField("quadratic_descent", centre=CENTRE, rates=self.rates(p))

    def start(self, p):
        rng = np.random.default_rng(int(p["seed"]))
        return np.array(CENTRE) + rng.uniform(-1.0, 1.0, size=(int(p["particles"]), 3))

    def t_end(self, p):
        return p["duration"] * 10.0 / p["lambda_max"]

    def dts(self, p):
        """h lambda_max = 0.1, 0.05, 0.025 (times h_scale)."""
        return [s * p["h_scale"] / p["lambda_max"] for s in (0.1, 0.05, 0.025)]

    def order_dts(self, p):
        return [0.01 * p["h_scale"] / p["lambda_max"]]

    def reference_dt(self, p):
        return 0.025 * p["h_scale"] / p["lambda_max"]

    def energy(self, p, obs):
        """Mean over particles of E(p) (m^2/s: E per unit mass-free 'energy')."""
        rel = np.asarray(obs["x"], float) - np.array(CENTRE)
        return np.mean(0.5 * np.einsum("...k,k,...k->...", rel, self.rates(p), rel), axis=-1)

    def energy_scale(self, p):
        rel = self.relative_start(p)
        return float(np.mean(0.5 * np.einsum("nk,k,nk->n", rel, self.rates(p), rel)))

    def extra_metrics(self, p, obs, observed, reference):
        """contraction_rate_slow_axis (1/s): ln(|p_1 - c_1|(t) / |p_1 - c_1|(0)) / t on axis 1
        (lambda_1) for the particle farthest from c along it: exactly ln|R(-h lambda_1)| / h,
        -lambda_1 for the flow (the slow axis stays far above the round-off of p itself)."""
        offset = np.asarray(obs["x"], float)[:, :, 0] - CENTRE[0]
        far = int(np.argmax(np.abs(offset[0])))
        t = float(np.asarray(obs["t"], float)[-1])
        with np.errstate(divide="ignore"):
            rate = np.log(np.abs(offset[-1, far]) / np.abs(offset[0, far])) / t
        return {"contraction_rate_slow_axis": float(rate)}


CASE = GradientDescent()
