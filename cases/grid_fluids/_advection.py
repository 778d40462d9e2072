"""What the advection cases (LeVeque's single vortex, Zalesak's slotted disk; issue 27, case 4)
share: a prescribed flow moving either a level set on the MAC cells or marker particles on the
shape's boundary, the exact shape as the reference, and bounds from each scheme's exact
discrete solution.

Two methods (parameter `method`):
- "level_set": phi = the exact signed distance of the shape on an n x n grid of cells, advected
  semi-Lagrangian (integrators "sl_<interpolant>:<backtrace>"). Compared observable
  `shape_error` (m^2): the symmetric-difference area between {phi < 0} and the exact shape at
  the sample time, by the area rule of refsim.models.grid_fluid.level_set (linear on 4
  triangles per dual cell, phi and the exact phi_e on the same triangles, their
  intersection exact per triangle): 0 at t = 0 up to round-off. Extra columns: `area_loss`
  (A(T) - A(0)) / A(0) by the same rule, and `area_rule_error` A_rule(phi_0) / A_exact - 1,
  the rule's own error on the exact initial shape.
- "particles": `markers` points on the shape's boundary (evenly by arc length), p' = u(t, p)
  by refsim's first-order steppers. Compared observable `shape_error` (m): the largest
  distance of a marker from its exact position (the polygon through the markers stays within
  it of the exact one's). Extra: `area_loss`, the markers' polygon (shoelace) area change
  relative to its start.

Bound, both methods: the exact discrete solution of the NAMED scheme, computed by the case
with its OWN velocity (`velocity`, written here, not imported from the model): the scheme's
error at these h and dt, so a flow the engine gets wrong (the time reversal dropped, a speed
0.1 % off) is caught whatever its size relative to the scheme's own error; the theory (the
bilinear level set's numerical diffusion, first order in h at a fixed CFL; the particle
steppers' orders in dt) is what that error measures, checked over grids and dt sweeps in
tests/cases/test_grid_fluids_advection.py. Round-off terms: see `tolerance`.
"""
from __future__ import annotations

import functools
import json

import numpy as np

from refsim.case import EPS, Case, Param
from refsim.integrators.first_order import get_first_order
from refsim.integrators.semi_lagrangian import parse_scheme
from refsim.models.advection import discrete_factors, propagate
from refsim.models.grid_fluid.level_set import LevelSetAdvection, area, symmetric_difference
from refsim.models.grid_fluid.mac import MacGrid
from refsim.scene import Grid, Particles, Scene
from refsim.scene.prescribed_flow import PrescribedFlow

METHODS = ("level_set", "particles")
# a level set's phi from another engine may differ from the oracle's by its roundings:
# DELTA_ROUNDINGS eps max|phi_0| a step (an interpolation sums 4 (bilinear) to 16 (cubic)
# weighted values, each product and sum rounding once), undamped over the run
DELTA_ROUNDINGS = 32


class CaseFlow:
    """The case's own velocity (the same expressions as the model's, written again here, so
    that a defect in the model's flow is not in the reference), as a first-order system."""

    def __init__(self, velocity_2d, matrix=None):
        self.velocity_2d, self.linear = velocity_2d, matrix is not None
        self.matrix = matrix

    def velocity(self, t, p):
        out = np.zeros_like(p, dtype=float)
        out[..., :2] = self.velocity_2d(t, p[..., :2])
        return out

    def jacobian(self, t, p):
        return self.matrix


def shoelace(x) -> np.ndarray:
    """Signed area (..., ) of the closed polygons x (..., n, >= 2) (counter-clockwise > 0)."""
    a, b = x[..., 0], x[..., 1]
    return 0.5 * np.sum(a * np.roll(b, -1, axis=-1) - np.roll(a, -1, axis=-1) * b, axis=-1)


class AdvectionCase(Case):
    """Subclasses define the shape (`sdf(p, points, t)`: its exact signed distance at time t,
    known at the sample times; `boundary(p, k)`: k boundary points, counter-clockwise;
    `exact_area(p)`), the flow (`flow_part(p)`, `velocity(p, t, points)`), `domain(p)` (side
    L of the square [0, L]^2), `t_end`, `steps_level_set(p)` and `particle_steps(p)`."""

    observable = "shape_error"
    units = "m^2"
    order_meaningful = True  # the particle variants sweep dt (the level set's: one dt each)
    common_params = {
        "method": Param("level_set", choices=METHODS),
        "n": Param(32, 8, 4096, "cells a side of the level set's grid"),
        "markers": Param(256, 8, 1e6, "boundary markers (particles)"),
    }

    # -- to define ------------------------------------------------------------------------------
    def domain(self, p) -> float:
        raise NotImplementedError

    def flow_part(self, p) -> PrescribedFlow:
        raise NotImplementedError

    def velocity(self, p, t, points):
        raise NotImplementedError

    def sdf(self, p, points, t=0.0):
        raise NotImplementedError

    def boundary(self, p, k):
        raise NotImplementedError

    def exact_area(self, p) -> float:
        raise NotImplementedError

    def exact_markers(self, p, t) -> np.ndarray:
        """(len(t), k, 2): where the flow has taken the markers at the sample times."""
        raise NotImplementedError

    def steps_level_set(self, p) -> int:
        raise NotImplementedError

    def particle_steps(self, p) -> list[int]:
        raise NotImplementedError

    # -- scene ----------------------------------------------------------------------------------
    def level_set(self, p) -> bool:
        return p["method"] == "level_set"

    def grid(self, p) -> MacGrid:
        n = int(p["n"])
        if n != p["n"]:
            raise ValueError(f"{self.name}.n must be an integer, got {p['n']}")
        return MacGrid(n, n, self.domain(p) / n)

    def markers(self, p) -> np.ndarray:
        return self.boundary(p, int(p["markers"]))

    def scene(self, p):
        if self.level_set(p):
            g = self.grid(p)
            part = Grid(shape=(g.nx, g.ny), spacing=g.h, origin=0.5 * g.h, model="level_set",
                        fields={"phi": self.sdf(p, g.cell_points())}, boundary="neumann")
        else:
            start = self.markers(p)
            part = Particles(mass=np.ones(len(start)),
                             position=np.column_stack([start, np.zeros(len(start))]))
        return Scene(parts=(part, self.flow_part(p)), dim=2)

    def observed(self, p):
        return ("shape_error", "m^2") if self.level_set(p) else ("shape_error", "m")

    def bodies(self, p):
        return int(p["n"]) ** 2 if self.level_set(p) else int(p["markers"])

    # -- time -----------------------------------------------------------------------------------
    def dts(self, p):
        if self.level_set(p):
            return [self.t_end(p) / self.steps_level_set(p)]
        return [self.t_end(p) / k for k in self.particle_steps(p)]

    def order_dts(self, p):
        """Particles: 4 x the finest timed step count, so the fit spans 16 x in dt."""
        return [] if self.level_set(p) else [self.t_end(p) / (4 * self.particle_steps(p)[-1])]

    def reference_dt(self, p):
        return self.dts(p)[-1] if self.level_set(p) else self.dts(p)[1]

    # -- observables ----------------------------------------------------------------------------
    def observables(self, p, obs):
        t = np.asarray(obs["t"], float)
        if self.level_set(p):
            g, phi = self.grid(p), np.asarray(obs["grid.phi"], float)
            exact = [self.sdf(p, g.cell_points(), tk) for tk in t]
            return {"shape_error": np.array([symmetric_difference(f, e, g.h)
                                             for f, e in zip(phi, exact)]),
                    "area": np.array([area(f, g.h) for f in phi])}
        x = np.asarray(obs["x"], float)[..., :2]
        gap = np.linalg.norm(x - self.exact_markers(p, t), axis=-1)
        return {"shape_error": np.max(gap, axis=-1), "area": shoelace(x)}

    def reference(self, p, t):
        return {"shape_error": np.zeros(len(np.asarray(t)))}

    def error(self, p, observed, reference):
        return np.abs(np.asarray(observed["shape_error"], float))

    def extra_metrics(self, p, obs, observed, reference):
        a = np.asarray(observed["area"], float)
        out = {"area_loss": float((a[-1] - a[0]) / a[0])}
        if self.level_set(p):
            out["area_rule_error"] = float(a[0] / self.exact_area(p) - 1.0)
        return out

    def energy(self, p, obs):
        """The shape's area (m^2), conserved by the divergence-free flow: the level set's by
        the area rule, the markers' polygon's by the shoelace formula; its drift column is the
        largest area change over the run relative to the exact area."""
        if "grid.phi" in obs:
            h = self.grid(p).h
            return np.array([area(f, h) for f in np.asarray(obs["grid.phi"], float)])
        if "x" in obs:
            return shoelace(np.asarray(obs["x"], float)[..., :2])
        return np.asarray(obs["area"], float)

    def energy_scale(self, p):
        return self.exact_area(p)

    def motion_scale(self, p):
        """Level set: the exact shape's area (m^2); particles: its size, max |x - centroid|."""
        if self.level_set(p):
            return self.exact_area(p)
        x = self.markers(p)
        return float(np.max(np.linalg.norm(x - x.mean(axis=0), axis=1)))

    def target_error(self, p):
        """1 % of the shape's area (level set), 1e-4 of its size (particles)."""
        return (1e-2 if self.level_set(p) else 1e-4) * self.motion_scale(p)

    # -- bounds ---------------------------------------------------------------------------------
    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        if self.level_set(p):
            return self._level_set_tolerance(p, integrator, dt, engine_variant)
        return self._particle_tolerance(p, integrator, dt)

    def _level_set_tolerance(self, p, integrator, dt, formulation=""):
        reinit = reinit_every(formulation)
        phi, steps = _oracle_level_set(self, json.dumps(p, sort_keys=True), integrator, dt,
                                       reinit)
        g = self.grid(p)
        exact = self.sdf(p, g.cell_points(), steps * dt)
        oracle = symmetric_difference(phi, exact, g.h)
        phi_max = float(np.max(np.abs(self.sdf(p, g.cell_points()))))
        delta = DELTA_ROUNDINGS * steps * EPS * phi_max
        band = 3.0 * (area(phi - delta, g.h) - area(phi + delta, g.h))
        return oracle + band, (
            f"the exact discrete solution of {integrator} (the scheme run by the case on its own "
            f"velocity, {steps} steps"
            f"{f', redistanced every {reinit} steps' if reinit else ''}): symmetric difference "
            f"{oracle:.6g} m^2; plus {band:.3g} "
            f"for a phi within delta = {DELTA_ROUNDINGS} n eps max|phi_0| = {delta:.3g} of it "
            "(another engine's roundings, undamped: the bilinear and clamped interpolants are "
            "convex combinations), 3 (A(phi - delta) - A(phi + delta)) (the rule's areas are "
            "monotone in each nodal value; a redistanced run in-house does the oracle's "
            "operations)")

    def _particle_tolerance(self, p, integrator, dt):
        gap, growth, steps = _oracle_particles(self, json.dumps(p, sort_keys=True), integrator,
                                               dt)
        scale = float(np.max(np.abs(self.markers(p)))) + self.motion_scale(p)
        roundoff = 4.0 * steps * EPS * growth * scale
        return gap + roundoff, (
            f"the exact discrete solution of {integrator} (its tableau run by the case on its "
            f"own velocity, {steps} steps; the closed form c + R(h M)^k (p_0 - c) on the "
            f"rotation): max marker error {gap:.6g} m at the samples; plus round-off "
            f"4 n eps G S = {roundoff:.3g} (S = {scale:.3g} m the largest |p| plus the shape's "
            f"size; G = {growth:.4g} the largest growth of a perturbation: max_k "
            "||R(h M)^k|| on the rotation, else ||J_n|| max_k ||J_k|| of the discrete flow's "
            "Jacobians J_k (area preserving: ||J^-1|| = ||J||) by finite differences; factor "
            "4: the oracle rounds as well)")


def reinit_every(formulation: str) -> int:
    """The engines' level-set formulations: "" (none) or "reinit_every_<k>" (phi redistanced
    after every k-th step, refsim.models.grid_fluid.level_set.redistance)."""
    if not formulation:
        return 0
    if not formulation.startswith("reinit_every_"):
        raise ValueError(f"level-set formulation must be '' or 'reinit_every_<k>', got "
                         f"{formulation!r}")
    return int(formulation.rsplit("_", 1)[1])


@functools.lru_cache(maxsize=32)
def _oracle_level_set(case, p_json, integrator, dt, reinit=0):
    """(phi at the end, steps) of the scheme run by the case on its own velocity."""
    p = json.loads(p_json)
    g = case.grid(p)
    interpolant, backtrace = parse_scheme(integrator)
    steps = int(round(case.t_end(p) / dt))
    model = LevelSetAdvection(case.sdf(p, g.cell_points()), g,
                              lambda t, x: case.velocity(p, t, x), interpolant, backtrace,
                              reinit)
    model.step(dt, steps)
    return model.phi, steps


PERTURBATION = 1e-7  # m x the shape's size: the Jacobians' finite differences


def _largest_singular_value(col_x, col_y) -> float:
    """max over markers of ||J||_2 for J = [col_x col_y] (2 x 2 each): sqrt of the larger
    eigenvalue of J^T J, (s + sqrt(s^2 - 4 det^2)) / 2, s the squared Frobenius norm."""
    s = np.sum(col_x ** 2 + col_y ** 2, axis=-1)
    det = col_x[:, 0] * col_y[:, 1] - col_x[:, 1] * col_y[:, 0]
    return float(np.max(np.sqrt(0.5 * (s + np.sqrt(np.maximum(s * s - 4 * det * det, 0.0))))))


@functools.lru_cache(maxsize=64)
def _oracle_particles(case, p_json, integrator, dt):
    """(max over the samples and markers of |p_k - p(t_k)| of the discrete solution, the
    perturbation growth G, steps). An affine flow (the rotation): the closed form
    c + R(h M)^k (p_0 - c) (refsim.models.advection) and G = max(1, max_k ||R(h M)^k||);
    otherwise the stepper run on the markers and two perturbed copies (G from their finite
    differences)."""
    p = json.loads(p_json)
    stepper = get_first_order(integrator)
    steps = int(round(case.t_end(p) / dt))
    stride = max(1, int(round(case.sample_dt(p) / dt)))
    sampled = np.unique(np.append(np.arange(0, steps, stride), steps))
    start = case.markers(p)
    if case.matrix(p) is not None:
        matrix, centre = case.matrix(p), np.append(case.pivot(p), 0.0)
        factors = discrete_factors(stepper, matrix, dt, sampled)
        disc = propagate(matrix, centre, np.column_stack([start, np.zeros(len(start))]),
                         factors)[..., :2]
        gap = np.linalg.norm(disc - case.exact_markers(p, sampled * dt), axis=-1)
        return float(np.max(gap)), max(1.0, float(np.max(np.abs(factors)))), steps
    flow = CaseFlow(lambda t, x: case.velocity(p, t, x), None)
    eps = PERTURBATION * case.motion_scale(p)
    copies = np.stack([start, start + [eps, 0.0], start + [0.0, eps]])
    state = np.concatenate([copies, np.zeros(copies.shape[:2] + (1,))], axis=-1)
    sampled, gaps, norms = set(sampled.tolist()), [], []
    for k in range(steps + 1):  # one step of all markers at a time (vectorised over them)
        if k in sampled:
            gaps.append(float(np.max(np.linalg.norm(
                state[0, :, :2] - case.exact_markers(p, np.array([k * dt]))[0], axis=-1))))
        norms.append(_largest_singular_value(
            (state[1, :, :2] - state[0, :, :2]) / eps, (state[2, :, :2] - state[0, :, :2]) / eps))
        if k < steps:
            state = stepper.step(flow, k * dt, state, dt)
    return max(gaps), max(1.0, norms[-1] * max(norms)), steps
