"""Witkin-Heckbert sampling of the unit sphere (slide 003; Witkin & Heckbert, "Using Particles
to Sample and Control Implicit Surfaces", SIGGRAPH 94): N particles repel with
E_ij = alpha exp(-|p_i - p_j|^2 / (2 sigma^2)), E_i = sum_j (E_ij + E_ji), and descend E_i
along the surface (tangential gradient), projected back onto the sphere after every step
(`refsim.models.surface_sampling`). sigma is FIXED: the paper adapts sigma_i per particle (and
splits and kills particles) to reach a target density; this case does not.

Reference: N = 4, 6, 12 end on the regular tetrahedron, octahedron, icosahedron (universally
optimal configurations: Cohn & Kumar 2007), whose neighbours subtend 109.47, 90 and 63.43 deg
at the centre. Compared observable `angle_error` (deg): max over particles and their 3, 4, 5
nearest neighbours of |angle - the polyhedron's|, bounded at the END of the run (err_final:
the start is random, seeded). The 'energy' is sum_i E_i, which decreases monotonically for
small h (`energy_rise` = the largest rise between samples, relative to E(0)).
No order: the fixed point is the same for every h and stepper; dt only sets how fast it is
reached. Tolerance (what it bounds: the angle error left at the end of the run): the flow's
own remaining error at T (a converged run) times the method's contraction of the slowest mode
at the polyhedron relative to the flow's, times one safety factor 2, plus round-off. A wrong
but stable method (Heun for RK4) reaches the same fixed point: this case cannot tell methods
apart, only their contraction rates.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from refsim.case import EPS, Case, Param
from refsim.integrators.first_order import get_first_order
from refsim.models.surface_sampling import (POLYHEDRA, SphereSampling, polyhedron_angle_error,
                                            polyhedron_vertices, relaxation_rates)
from refsim.scene import Particles, Scene
from refsim.scene.surface_sampling import SurfaceSampling

ROTATION_RATE_CUT = 1e-6  # |rate| below this x the largest: a rigid rotation (zero mode)


class SphereSamplingCase(Case):
    name = "sphere_sampling"
    description = ("Witkin-Heckbert repulsion on a sphere (fixed sigma): N = 4, 6, 12 reach "
                   "the tetrahedron, octahedron, icosahedron")
    tags = ("particle_fields", "first_order", "sampling")
    observable, units = "angle_error", "deg"
    tolerance_norm = "err_final"
    order_meaningful = False
    initial_state_is_reference = False  # the reference is the end state (the polyhedron)
    params = {
        "particles": Param(4, choices=("4", "6", "12"), doc="N: 4, 6 or 12"),
        "sigma": Param(0.7, 0.0, 10.0, "repulsion width (m), fixed", low_inclusive=False),
        "alpha": Param(1.0, 0.0, 1e6, "repulsion amplitude", low_inclusive=False),
        "duration": Param(12.0, 0.0, 1e5, "s", low_inclusive=False),
        "seed": Param(14, 0, 2 ** 31, "random start's seed"),
    }
    variants = {"tetrahedron": {}, "octahedron": {"particles": "6"},
                "icosahedron": {"particles": "12", "sigma": 0.5}}
    quick_variants = ("tetrahedron",)
    default_variants = ("tetrahedron", "octahedron")

    def count(self, p) -> int:
        return int(p["particles"])

    def bodies(self, p):
        return self.count(p)

    def system(self, p) -> SphereSampling:
        return SphereSampling(1.0, (0.0, 0.0, 0.0), p["sigma"], p["alpha"])

    def start(self, p):
        rng = np.random.default_rng(int(p["seed"]))
        return self.system(p).project(rng.normal(size=(self.count(p), 3)))

    def scene(self, p):
        part = SurfaceSampling(radius=1.0, sigma=p["sigma"], alpha=p["alpha"])
        return Scene(parts=(Particles(mass=np.ones(self.count(p)), position=self.start(p)),
                            part))

    def t_end(self, p):
        return p["duration"]

    def dts(self, p):
        return [0.05, 0.025]

    def reference_dt(self, p):
        return 0.025

    def motion_scale(self, p):
        """180 deg: the largest angle error possible."""
        return 180.0

    def observables(self, p, obs):
        return {"angle_error": polyhedron_angle_error(np.asarray(obs["x"], float), np.zeros(3))}

    def reference(self, p, t):
        return {"angle_error": np.zeros(len(np.asarray(t)))}

    def energy(self, p, obs):
        return self.system(p).energy(np.asarray(obs["x"], float))

    def energy_scale(self, p):
        return float(self.system(p).energy(self.start(p)))

    def extra_metrics(self, p, obs, observed, reference):
        energy = self.energy(p, obs)
        return {"energy_rise": float(max(0.0, np.max(np.diff(energy)))) / energy[0],
                "polyhedron": POLYHEDRA[self.count(p)][0]}

    def contraction(self, p, integrator, dt) -> tuple[float, float]:
        """(rho, slowest rate): rho = max |R(h lambda_k)| over the non-rotation modes of the
        descent linearised at the polyhedron (`relaxation_rates`)."""
        system = self.system(p)
        rates = relaxation_rates(system, polyhedron_vertices(self.count(p)))
        modes = rates[np.abs(rates) > ROTATION_RATE_CUT * np.max(np.abs(rates))]
        rho = float(np.max(np.abs(get_first_order(integrator).stability(dt * modes))))
        return rho, float(np.min(np.abs(modes)))

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        rho, slowest = self.contraction(p, integrator, dt)
        steps = int(round(self.t_end(p) / dt))
        flow = flow_final_error(tuple(sorted(p.items())))
        # the slowest mode's amplitude after the run: the method's rho^n against the flow's
        # exp(-lambda_slow T); the fixed point's modes decouple, so the method's remaining
        # error is the flow's times that ratio
        ratio = float(np.exp(steps * np.log(rho) + slowest * self.t_end(p)))
        expected = flow * ratio
        # a step rounds each unit p by <= 4 eps (stages, projection's norm and division); the
        # fixed point damps each rounding by rho a step: <= 4 eps / (1 - rho) rad left; the
        # angle's arccos adds <= 4 eps / sin(theta) rad (theta >= 63 deg: <= 5 eps)
        roundoff = float(np.degrees(4.0 * EPS / max(1.0 - rho, EPS) + 5.0 * EPS))
        return SAFETY * expected + roundoff, (
            f"{SAFETY:g} x {expected:.4g} deg: the flow's own angle error left at T "
            f"({flow:.4g} deg: RK4 at h = {REFERENCE_STEP:g} s, whose contraction per step "
            "matches the flow's to (h lambda)^5 / 120) times the method's contraction of the "
            f"slowest mode at the polyhedron against the flow's, rho^n exp(lambda_slow T) = "
            f"{ratio:.4g} (rho = max|R(h lambda_k)| = {rho:.6g}, lambda_slow = {slowest:.4g} "
            "1/s, rigid rotations excluded); safety factor "
            f"{SAFETY:g} for the approach before the linear regime (measured: the real error "
            "is 1.00..1.11 of this on the default sweep); plus round-off "
            f"{roundoff:.3g} deg (4 eps per step damped by 1 - rho, 5 eps in the arccos)")


SAFETY = 2.0  # the one safety factor of the tolerance
REFERENCE_STEP = 0.005  # s: the flow's stand-in, RK4 (first-order stepper) at this step


@lru_cache(maxsize=8)
def flow_final_error(key) -> float:
    """The flow's angle error (deg) at T from the case's start: the first-order RK4 stepper at
    REFERENCE_STEP (its step factor R(-h lambda) = exp(-h lambda) (1 + O((h lambda)^5))), the
    projection after every step as in a run."""
    p = dict(key)
    steps = int(round(CASE.t_end(p) / REFERENCE_STEP))
    h = CASE.t_end(p) / steps
    _, end = get_first_order("rk4").advance(CASE.system(p), 0.0, CASE.start(p), h, steps)
    return float(polyhedron_angle_error(end[None], np.zeros(3))[0])


CASE = SphereSamplingCase()
