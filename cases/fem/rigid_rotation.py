"""Rigid rotation (slide 001's strain measures): a free plane-stress plate W x H = 1 x 0.5 m
(thickness 0.1 m, E = 1000 Pa, nu = 0.3, rho = 1 kg/m^3, `cells` x cells/2 right-triangle
cells) starts in its rest shape rotated rigidly by theta about its centre, x0 = c + R (X - c),
drifting at a uniform velocity v0 = (0.02, 0.01) m/s (a translation: exact for every law and
stepper, so that even the laws that find no force move); no pins, loads or gravity. A
dynamic case, stepped (why not static: a free body's stiffness is singular, and pinning
nodes at R X would turn the rotation into an imposed boundary field; released, the force a
law finds in a rotated body shows directly as motion, one scene for every law, with exact
references for every stepper).

- green (StVK), corotated, neo_hookean are rotation invariant: at F = R their stress is zero,
  every node's force is round-off and the exact motion is "stays put": x(t) = x0 + v0 t.
- linear (Cauchy as printed, eps = 1/2 (F + F^T) - I) reads F = R as the spurious strain
  eps = (cos theta - 1) I in every element: the stress sigma0 I, sigma0 = E (cos theta - 1) /
  (1 - nu) (plane stress, lam* = E nu / (1 - nu^2)), pushes each boundary node outward in the
  REST frame (P = sigma is not rotated): f_a = -sigma0 t/2 sum_edges l n over the boundary
  edges at a (outward unit normals n, lengths l; interior nodes get zero), so the body starts
  with the acceleration a0 = f / m (lumped m = rho t A / 3 per corner): x = x0 + a0 t^2 / 2 +
  O(t^3) (plus v0 t). Its forces are affine, f = -K (x - X), so the whole motion is the
  linear system x'' = -M^-1 K (x - X), solved exactly by its modes (K, M written out in
  cases/fem/_linear.py, independent of refsim.models): a vibration about the contracted
  body it never leaves.
Run: half the lowest elastic period (pi / omega_1: the spurious vibration's first extreme);
steps y = omega_max dt = 0.1 (reference; omega_max the mesh's highest mode), and 0.2 beside
it in the variant linear_sweep (the default run's cost: the dt sweep by name).
Observable: every node's position x (m); error the 2-norm over the nodes.
Bounds: linear: the named method's exact discrete solution on the same linear system
(refsim.expected) against the exact modal solution, max over the samples, plus round-off;
the invariant laws: round-off only. Round-off: each force component rounds to at most
ROUNDING_TERMS eps lambda_max(K) max|x| (cases/fem/_static.py), an acceleration of at most
a_r = sqrt(dofs) that / m_min in the 2-norm, and any force bounded by F moves an oscillator
(or a free mode) by at most F t^2 / 2 (|sin(w s) / w| <= s); the discrete methods' modal
response differs from the flow's by O(y^2) <= 1 % at y <= 0.2: factor 2; plus the steppers'
own n eps S (refsim.case.roundoff_tolerance); explicit Euler multiplies any error by its
amplitude growth (1 + y_max^2)^(n/2). A law that is not rotation invariant misses it by the
spurious motion: the Cauchy law's run is 0.30 m (2-norm over the nodes) from x0 + v0 t at the
run's end, 3e9 x the round-off bound.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from refsim.case import EPS, Case, Param, roundoff_tolerance, sample_steps
from refsim.expected import discrete_solution
from refsim.integrators.spec import spec_name
from refsim.models.fem.meshes import rectangle_triangles
from refsim.scene import Material, Scene, TriangleMesh
from refsim.scene.meshes import STRAIN_MEASURES

from . import _linear
from ._static import ROUNDING_TERMS

WIDTH, HEIGHT, THICKNESS, DENSITY = 1.0, 0.5, 0.1, 1.0
DRIFT = np.array([0.02, 0.01, 0.0])  # m/s, the uniform translation
Y_SWEEP = (0.2, 0.1)
Y_REFERENCE = 0.1
SAFETY = 2.0  # the discrete methods' constant-force response vs the flow's (docstring)


@lru_cache(maxsize=16)
def linear_system(cells, youngs_modulus, poisson_ratio):
    """(rest nodes (n, 3), triangles, K (2n, 2n) dense, lumped masses per dof (2n,)) of the
    plate, from cases/fem/_linear.py."""
    nodes, tris = rectangle_triangles(int(cells), max(1, int(cells) // 2), WIDTH, HEIGHT)
    k = _linear.stiffness(nodes, tris, youngs_modulus, poisson_ratio, THICKNESS).toarray()
    m = np.repeat(_linear.lumped_mass(nodes, tris, DENSITY, THICKNESS), 2)
    return nodes, tris, k, m


@lru_cache(maxsize=16)
def modes(cells, youngs_modulus, poisson_ratio):
    """(omega (2n,) rad/s, ascending; Q (2n, 2n)) of M^-1/2 K M^-1/2 = Q diag(omega^2) Q^T;
    the rigid modes' round-off eigenvalues (|lambda| <= 1e-12 lambda_max) set to 0."""
    _, _, k, m = linear_system(cells, youngs_modulus, poisson_ratio)
    s = 1.0 / np.sqrt(m)
    lam, q = np.linalg.eigh(s[:, None] * k * s[None, :])
    lam[np.abs(lam) <= 1e-12 * lam[-1]] = 0.0
    return np.sqrt(lam), q


class RigidRotation(Case):
    name = "rigid_rotation"
    description = ("free plate released at rest, rotated rigidly by 30 degrees: invariant laws "
                   "stay put, Cauchy's spurious strain (cos theta - 1) I sets it vibrating")
    tags = ("fem", "dynamic", "closed form", "exact")
    observable, units = "x", "m"
    params = {
        "strain": Param("linear", choices=STRAIN_MEASURES),
        "theta_deg": Param(30.0, -180.0, 180.0, "rotation angle (degrees)"),
        "cells": Param(4, 2, 32, "cells along the 1 m side (half as many across)"),
        "youngs_modulus": Param(1000.0, 1e-6, 1e12, "E (Pa)", low_inclusive=False),
        "poisson_ratio": Param(0.3, -0.99, 0.49, "nu"),
        "dt_sweep": Param("reference", choices=("reference", "full"),
                          doc="the reference dt alone (the default run's cost) or the sweep"),
    }
    variants = {"linear": {}, "corotated": {"strain": "corotated"},
                "green": {"strain": "green"}, "neo_hookean": {"strain": "neo_hookean"},
                "linear_sweep": {"dt_sweep": "full"}}
    default_variants = ("linear", "green")  # green: the law MuJoCo's flex runs
    # the slides' printed force is zero at zero stress, as correct: shown where stress is not
    alternatives_variants = ("linear",)
    quick_variants = ("linear",)

    def _key(self, p):
        return int(p["cells"]), p["youngs_modulus"], p["poisson_ratio"]

    def _rotation(self, p):
        c, s = np.cos(np.radians(p["theta_deg"])), np.sin(np.radians(p["theta_deg"]))
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def rotated(self, p) -> np.ndarray:
        """(n, 3) x0 = c + R (X - c)."""
        nodes = linear_system(*self._key(p))[0]
        centre = np.array([WIDTH / 2, HEIGHT / 2, 0.0])
        return centre + (nodes - centre) @ self._rotation(p).T

    def scene(self, p):
        nodes, tris, _, _ = linear_system(*self._key(p))
        material = Material(p["youngs_modulus"], p["poisson_ratio"], DENSITY, p["strain"])
        mesh = TriangleMesh(nodes, tris, material, thickness=THICKNESS, plane="stress",
                            positions=self.rotated(p),
                            velocities=np.repeat(DRIFT[None], len(nodes), 0))
        return Scene(parts=(mesh,), gravity=(0.0, 0.0, 0.0))

    def bodies(self, p):
        return len(linear_system(*self._key(p))[0])

    def omegas(self, p) -> tuple[float, float]:
        """(omega_1, the lowest elastic mode; omega_max) in rad/s."""
        omega, _ = modes(*self._key(p))
        return float(omega[omega > 0][0]), float(omega[-1])

    def t_end(self, p):
        return np.pi / self.omegas(p)[0]

    def dts(self, p):
        if p["dt_sweep"] == "reference":
            return [self.reference_dt(p)]
        return [y / self.omegas(p)[1] for y in Y_SWEEP]

    def reference_dt(self, p):
        return Y_REFERENCE / self.omegas(p)[1]

    def observables(self, p, obs):
        return {"x": np.asarray(obs["x"], float)}

    def exact_linear(self, p, t) -> np.ndarray:
        """(len(t), n, 3) the Cauchy law's exact motion: x(t) = X + M^-1/2 Q [cos(omega t)
        Q^T M^1/2 (x0 - X) + sin(omega t) / omega Q^T M^1/2 v0] (t for omega = 0)."""
        nodes, _, _, m = linear_system(*self._key(p))
        omega, q = modes(*self._key(p))
        u0 = (self.rotated(p) - nodes)[:, :2].reshape(-1)
        v0 = np.tile(DRIFT[:2], len(nodes))
        coeff, rate = q.T @ (np.sqrt(m) * u0), q.T @ (np.sqrt(m) * v0)
        wt = np.outer(np.atleast_1d(t), omega)
        moving = np.where(omega > 0, np.sin(wt) / np.where(omega > 0, omega, 1.0),
                          np.atleast_1d(t)[:, None])
        u = (np.cos(wt) * coeff + moving * rate) @ q.T / np.sqrt(m)
        out = np.repeat(nodes[None], len(u), 0)
        out[..., :2] += u.reshape(len(u), -1, 2)
        return out

    def reference(self, p, t):
        t = np.atleast_1d(np.asarray(t, float))
        if p["strain"] == "linear":
            return {"x": self.exact_linear(p, t)}
        return {"x": self.rotated(p)[None] + t[:, None, None] * DRIFT}

    def spurious_force(self, p) -> np.ndarray:
        """(n, 2) the Cauchy law's nodal forces at x0 in closed form: -sigma0 t/2 sum l n over
        each node's boundary edges (rest frame), sigma0 = E (cos theta - 1) / (1 - nu)."""
        nodes = linear_system(*self._key(p))[0][:, :2]
        sigma0 = p["youngs_modulus"] * (np.cos(np.radians(p["theta_deg"])) - 1.0) / (
            1.0 - p["poisson_ratio"])
        nx = int(p["cells"])
        hx, hy = WIDTH / nx, HEIGHT / max(1, nx // 2)
        # sum over a node's boundary edges of (l / 2) n: a side node gets its two half
        # edges (l along the side, normal out of it), a corner one half edge on each side
        weight = np.zeros_like(nodes)
        for axis, h_along, top in ((0, hy, HEIGHT), (1, hx, WIDTH)):
            coordinate, along = nodes[:, axis], nodes[:, 1 - axis]
            share = np.where((along == 0.0) | (along == top), 0.5, 1.0) * h_along
            weight[:, axis] += np.where(coordinate == (WIDTH, HEIGHT)[axis], share, 0.0)
            weight[:, axis] -= np.where(coordinate == 0.0, share, 0.0)
        return -sigma0 * THICKNESS * weight

    def energy(self, p, obs):
        """Kinetic plus the linear law's elastic energy 1/2 u^T K u (J): conserved by the
        Cauchy variant's flow; for the invariant laws the linearisation at x0's rest frame is
        not their energy, so None there."""
        if p["strain"] != "linear":
            return None
        nodes, _, k, m = linear_system(*self._key(p))
        u = (np.asarray(obs["x"], float) - nodes)[..., :2].reshape(len(obs["x"]), -1)
        v = np.asarray(obs["v"], float)[..., :2].reshape(len(obs["x"]), -1)
        return 0.5 * np.einsum("si,ij,sj->s", u, k, u) + 0.5 * (v * v) @ m

    def energy_scale(self, p):
        """The energy Cauchy's spurious strain stores at x0 (J)."""
        nodes, _, k, _ = linear_system(*self._key(p))
        u0 = (self.rotated(p) - nodes)[:, :2].reshape(-1)
        return float(0.5 * u0 @ k @ u0)

    def motion_scale(self, p):
        """The spurious contraction's size ||(1 - cos theta)(X - c)||_2 (m), the same for
        every law (the invariant ones do not move)."""
        nodes = linear_system(*self._key(p))[0]
        centre = np.array([WIDTH / 2, HEIGHT / 2, 0.0])
        spurious = 1.0 - np.cos(np.radians(p["theta_deg"]))
        return float(spurious * np.linalg.norm(nodes - centre))

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        nodes, _, k, m = linear_system(*self._key(p))
        steps = int(round(self.t_end(p) / dt))
        x0 = self.rotated(p)
        lam_max = float(np.linalg.eigvalsh(k)[-1])
        size = float(np.abs(x0).max() + np.abs(DRIFT).max() * steps * dt)
        accel = np.sqrt(k.shape[0]) * ROUNDING_TERMS * EPS * lam_max * size / m.min()
        forced = SAFETY * accel * (steps * dt) ** 2 / 2.0
        state, state_reason = roundoff_tolerance(steps, 0.5 * np.sqrt(x0.size) * size)
        growth = 1.0
        if spec_name(integrator) == "explicit_euler":
            growth = (1.0 + (self.omegas(p)[1] * dt) ** 2) ** (steps / 2.0)
        roundoff = growth * (forced + state)
        reason = (f"; round-off: forces rounded to {ROUNDING_TERMS} eps lambda_max "
                  f"{lam_max:.3g} N/m max|x|, moving the nodes by at most {SAFETY:g} a_r t^2/2 "
                  f"= {forced:.3g} m" + state_reason
                  + (f"; times explicit Euler's growth {growth:.3g}" if growth > 1 else ""))
        if p["strain"] != "linear":
            return roundoff, "rotation invariant: the exact motion stays at x0" + reason
        k_steps = sample_steps(steps, int(round(self.sample_dt(p) / dt)))
        u0 = (x0 - nodes)[:, :2].reshape(-1)
        u, _ = discrete_solution(integrator, -k / m[:, None], None, u0,
                                 np.tile(DRIFT[:2], len(nodes)), dt, k_steps)
        exact = (self.exact_linear(p, k_steps * dt) - nodes)[..., :2].reshape(len(k_steps), -1)
        deviation = float(np.max(np.linalg.norm(u - exact, axis=1)))
        return deviation + roundoff, (
            f"{integrator}'s exact discrete solution of x'' = -M^-1 K (x - X) "
            f"(refsim.expected; "
            f"y = omega_max dt = {self.omegas(p)[1] * dt:.3g}) errs {deviation:.3g} m from the "
            f"modal solution at the {len(k_steps)} samples (max)" + reason)


CASE = RigidRotation()
