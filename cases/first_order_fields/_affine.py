"""What the affine-field cases (advection in a rigid vortex, gradient descent on a quadratic)
share: the particles' start, the compared position error against the continuum flow, and the
tolerance built from the exact discrete solution of each stepper.

For u = M (p - c), every stepper of `refsim.integrators.first_order` maps p - c to S (p - c) per
step, S = R(h M) (its stability function at h M), so after k steps p_k = c + S^k (p_0 - c)
exactly, while the flow gives c + expm(t M) (p_0 - c). The compared error, max over particles
of |p_k - p(t_k)|, is therefore known before the run: max_i |(S^k - expm(t_k M)) (p_i - c)|,
and the tolerance is that exact discrete deviation plus the round-off the run may add.
"""
from __future__ import annotations

import numpy as np

from refsim.case import EPS, Case
from refsim.integrators.first_order import get_first_order
from refsim.models.advection import (discrete_factors, exact_positions, flow_factors,
                                     propagate)
from refsim.scene import Particles, Scene
from refsim.scene.velocity_field import VelocityField


class AffineFieldCase(Case):
    """Subclasses define `field(p)` (a VelocityField), `start(p)` ((n, 3) positions)."""

    observable, units = "x_error", "m"
    order_meaningful = True

    def field(self, p) -> VelocityField:
        raise NotImplementedError

    def start(self, p) -> np.ndarray:
        raise NotImplementedError

    def bodies(self, p):
        return int(p["particles"])

    def scene(self, p):
        start = self.start(p)
        return Scene(parts=(Particles(mass=np.ones(len(start)), position=start),
                            self.field(p)))

    def relative_start(self, p) -> np.ndarray:
        return self.start(p) - np.array(self.field(p).centre)

    def motion_scale(self, p):
        """The largest distance of a particle from the centre (m)."""
        return float(np.max(np.linalg.norm(self.relative_start(p), axis=1)))

    def observables(self, p, obs):
        x = np.asarray(obs["x"], float)
        exact = exact_positions(self.field(p).matrix(), np.array(self.field(p).centre),
                                self.start(p), obs["t"])
        return {"x_error": np.max(np.linalg.norm(x - exact, axis=-1), axis=-1)}

    def reference(self, p, t):
        return {"x_error": np.zeros(len(np.asarray(t)))}

    def sampled_steps(self, p, dt) -> np.ndarray:
        """The step counts the job observes at (stride as refsim/run/job.py computes it)."""
        steps = int(round(self.t_end(p) / dt))
        stride = max(1, int(round(self.sample_dt(p) / dt)))
        return np.unique(np.append(np.arange(0, steps + 1, stride), steps))

    def discrete_deviation(self, p, integrator, dt) -> tuple[float, float]:
        """(max over the sampled steps and particles of |p_k - p(t_k)| for the exact discrete
        solution, max over those steps of ||R(h M)^k||_2 = max |R(h lambda)|^k (M normal):
        the largest growth of a perturbation)."""
        matrix, steps = self.field(p).matrix(), self.sampled_steps(p, dt)
        discrete = discrete_factors(get_first_order(integrator), matrix, dt, steps)
        gap = propagate(matrix, np.zeros(3), self.relative_start(p),
                        discrete - flow_factors(matrix, steps * dt))
        worst = float(np.max(np.linalg.norm(gap, axis=-1)))
        return worst, max(1.0, float(np.max(np.abs(discrete))))

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        deviation, growth = self.discrete_deviation(p, integrator, dt)
        steps = int(round(self.t_end(p) / dt))
        scale = float(np.max(np.linalg.norm(self.start(p), axis=1))) + \
            growth * self.motion_scale(p)
        roundoff = 2.0 * steps * EPS * growth * scale
        return deviation + roundoff, (
            f"the exact discrete solution c + R(h M)^k (p_0 - c) of {integrator} (R its "
            f"stability function) deviates from the flow by at most {deviation:.6g} m at the "
            f"samples; plus round-off 2 n eps G S = {roundoff:.3g} (n = {steps} steps, each "
            f"rounding p by eps |p| <= eps S, S = {scale:.3g} m the largest |p|; a rounding "
            f"grows by at most G = max_k ||R(h M)^k||_2 = {growth:.4g} over the run; factor 2: "
            "the oracle's and the flow's modal evaluations round too, by fewer operations)")
