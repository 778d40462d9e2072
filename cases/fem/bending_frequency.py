"""First bending frequency of a plane-stress cantilever: L = 1 m, depth D = L / 4 (`aspect`
L/D = 4), unit thickness, E = 1000 Pa, nu = 0.3, rho = 1 kg/m^3, linear law (small strain: the
frequency does not depend on the amplitude), its edge x = 0 clamped (pinned), `cells` right-
triangle cells across the depth and aspect x as many along; lumped masses rho t A / 3 per
corner (refsim's and the dynamic engines' mass; the consistent mass is not used anywhere here).

Euler-Bernoulli: omega_EB = 1.87510407^2 sqrt(E I / (rho A L^4)), I = t D^3 / 12, A = t D.
The plane-stress continuum is slower (shear deformation, rotary inertia): refsim's converged
ratio omega_2D / omega_EB from the lumped-mass P1 eigen-solve on ny = 4, 8, 16, 32 cells
across (stored in STUDY, K and M from cases/fem/_linear.py, scipy eigsh shift-invert; tests/
cases/test_fem_bending_frequency.py recomputes them with refsim's assembler), Richardson at
the observed order (1.92 at L/D = 4, 1.97 at 20) and at order 2, mean +- difference:
    L/D = 4: 0.95721 +- 0.00013,   L/D = 20: 0.99858 +- 0.00004
(about 0.957 and 0.999 as stated for this model). Timoshenko beam theory at first order,
omega / omega_EB = sqrt(1 - (r/L)^2 (R + S E / (kappa G))), r^2 = D^2 / 12, R = L^2 int phi'^2
/ int phi^2 = 4.6478 and S = L^2 int phi'''^2 / int phi''^2 = 4.6478 over the EB mode, kappa =
10 (1 + nu) / (12 + 11 nu) (Cowper 1966), gives 0.99803 at L/D = 20 and 0.9496 at 4: the 2D
clamped edge (u = v = 0 along x = 0) also forbids the shear strain a beam's clamp allows, so
the 2D model stays 28 % closer to EB than the beam correction at L/D = 20 (`beam_correction`).

The matrix run (dynamic): the mesh starts at rest in its own first mode phi (the lumped-mass
generalised eigenvector of the free dofs, dense scipy.linalg.eigh), scaled so the tip's
mid-depth node is displaced A = 0.01 m; the exact motion of the semi-discrete system is
u(t) = A phi cos(omega_h t), omega_h the mesh's first frequency (P1 locking: 1.27 omega_EB at
cells = 2, 1.05 at 4). Observable: tip_v, that node's vertical displacement (m), one period.
Extra columns: the period measured from the tip's two zero crossings (linear interpolation
between samples) and omega / omega_EB from it, beside omega_h / omega_EB and the continuum's.
Bound: the named method's exact discrete solution of q'' = -omega_h^2 q (refsim.expected)
against A cos(omega_h t), max over the samples, plus round-off as in cases/fem/
rigid_rotation.py (forces' rounding through F t^2 / 2 with a factor 2, n eps S, explicit
Euler's growth (1 + y_max^2)^(n/2) on the stiffest mode, which it diverges on: y_max =
omega_max dt = 1.6 at the reference dt, omega_max / omega_h = 75). Steps: y_max = 1.6, and 0.8
beside it in the variant n2_sweep (the default run's cost: the sweep by name); both below 2,
where symplectic Euler and velocity Verlet turn unstable on the stiffest mode.
An E 0.1 % off shifts omega_h by 0.05 %, a phase of 3e-3 rad over the period: 22-24x
the velocity Verlet bound and 180x RK4's at the reference dt (test).
Variant n2_green (StVK, MuJoCo's flex law, outside default_variants): the same mesh, mode and
omega_h (StVK's tangent at rest is the linear law's K), A = 3e-4 m. The geometric
nonlinearity is bounded in the tolerance: StVK's forces are exactly -K u + g2(u) + g3(u)
(quadratic and cubic, g2 and g3 from the forces at +-A phi), so along u = A phi cos(omega_h t)
each mode j of (K, M) (M-orthonormal psi_j) is forced by a_j cos^2 + b_j cos^3 = a_j/2 (1 +
cos 2 w t) + b_j (3 cos w t + cos 3 w t)/4; Duhamel's integral of each term is bounded by
2 / |omega_j^2 - nu^2| (t / (2 omega_h) on resonance, mode 1's cos w t: the frequency shift);
the tip's bound sums |psi_j,tip| times those, times NL_SAFETY = 2 (the forces taken along
the nonlinear path rather than the linear one, and the higher orders: valid while the bound
is << A, here 6e-4 A). Measured: 1.7e-7 m bound against a 1.9-2.1e-8 m nonlinear effect
(the in-house green run against its linear run). E 0.1 % off is 2.1-2.5x the Verlet and RK4
bounds there (3.0-3.3e-7 m: the case's round-off term 1.3e-7 m and the nonlinearity's); A
= 3e-4 m is near the best ratio (signal ~ A, nonlinearity ~ A^2, round-off fixed).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
import scipy.linalg

from refsim.case import EPS, Case, Param, roundoff_tolerance, sample_steps
from refsim.expected import discrete_solution
from refsim.integrators.spec import spec_name
from refsim.models.fem.meshes import rectangle_triangles
from refsim.models.fem.model import ElasticBody
from refsim.scene import Material, Scene, TriangleMesh

from . import _linear
from ._static import ROUNDING_TERMS

BETA_L = 1.87510407  # the first root of 1 + cos(x) cosh(x) = 0
LENGTH, THICKNESS = 1.0, 1.0
Y_SWEEP = (1.6, 0.8)  # below 2, the symplectic steppers' stability limit on the stiffest mode
Y_REFERENCE = 1.6
SAFETY = 2.0  # the discrete methods' response to a bounded force vs the flow's
NL_SAFETY = 2.0  # the StVK forces along the nonlinear path vs the linear one (docstring)
# omega_h / omega_EB of the lumped-mass P1 mesh, L/D -> {cells across: ratio} (docstring)
STUDY = {4: {4: 1.0513356101197089, 8: 0.9826661739968154, 16: 0.9638940053576284,
             32: 0.9589297052357562},
         20: {4: 1.1013056820562135, 8: 1.0253871731128443, 16: 1.0053999295142828,
              32: 1.000304632905035}}


def converged(values) -> tuple[float, float, float]:
    """(value, error estimate, observed order) from the last three of a halving sequence:
    Richardson at the observed order p and at order 2, their mean and difference."""
    a, b, c = values[-3:]
    order = float(np.log2((b - a) / (c - b)))
    at_p, at_2 = c + (c - b) / (2.0 ** order - 1.0), c + (c - b) / 3.0
    return 0.5 * (at_p + at_2), abs(at_2 - at_p), order


def beam_correction(aspect, poisson_ratio) -> float:
    """Timoshenko beam theory's first-order omega / omega_EB (docstring), the EB mode's
    integrals by Gauss-Legendre (64 points: the integrands are smooth)."""
    s, w = np.polynomial.legendre.leggauss(64)
    s, w = (s + 1) / 2, w / 2
    b = BETA_L
    sigma = (np.cosh(b) + np.cos(b)) / (np.sinh(b) + np.sin(b))
    ch, c, sh, sn = np.cosh(b * s), np.cos(b * s), np.sinh(b * s), np.sin(b * s)
    phi, d1 = ch - c - sigma * (sh - sn), b * (sh + sn - sigma * (ch - c))
    d2, d3 = b * b * (ch + c - sigma * (sh + sn)), b ** 3 * (sh - sn - sigma * (ch + c))
    rotary, shear = (w @ d1 ** 2) / (w @ phi ** 2), (w @ d3 ** 2) / (w @ d2 ** 2)
    kappa = 10 * (1 + poisson_ratio) / (12 + 11 * poisson_ratio)
    ratio = 2 * (1 + poisson_ratio) / kappa  # E / (kappa G)
    return float(np.sqrt(1 - (rotary + shear * ratio) / (12 * aspect ** 2)))


@lru_cache(maxsize=16)
def first_mode(cells, aspect, youngs_modulus, poisson_ratio, density):
    """(nodes, triangles, omega_h, phi (n, 2) with tip v = 1, omega_max, K, masses per dof)
    of the clamped mesh (cases/fem/_linear.py; dense generalised eigen-solve)."""
    ny = int(cells)
    nx = int(round(ny * aspect))
    nodes, tris = rectangle_triangles(nx, ny, LENGTH, LENGTH / aspect)
    k = _linear.stiffness(nodes, tris, youngs_modulus, poisson_ratio, THICKNESS).toarray()
    m = np.repeat(_linear.lumped_mass(nodes, tris, density, THICKNESS), 2)
    free = np.repeat(nodes[:, 0] > 0.0, 2)
    lam, vec = scipy.linalg.eigh(k[np.ix_(free, free)], np.diag(m[free]))
    phi = np.zeros(2 * len(nodes))
    phi[free] = vec[:, 0]
    phi = phi.reshape(-1, 2)
    phi /= phi[tip_node(nodes, aspect), 1]
    return nodes, tris, float(np.sqrt(lam[0])), phi, float(np.sqrt(lam[-1])), k, m


def tip_node(nodes, aspect) -> int:
    return int(np.flatnonzero((nodes[:, 0] == LENGTH) &
                              (np.abs(nodes[:, 1] - LENGTH / aspect / 2) <= 1e-12))[0])


class BendingFrequency(Case):
    name = "bending_frequency"
    description = ("plane-stress cantilever (L/D 4) started in its first mode: the tip's "
                   "period against the mesh's eigenfrequency; Euler-Bernoulli and the "
                   "converged 2D ratio beside it")
    tags = ("fem", "dynamic", "frequency", "exact")
    observable, units = "tip_v", "m"
    params = {
        "cells": Param(2, 2, 16, "cells across the depth (even: a mid-depth tip node)"),
        "aspect": Param(4, 1, 40, "L / D"),
        "youngs_modulus": Param(1000.0, 1e-6, 1e12, "E (Pa)", low_inclusive=False),
        "poisson_ratio": Param(0.3, -0.99, 0.49, "nu"),
        "density": Param(1.0, 1e-6, 1e6, "rho (kg/m^3)", low_inclusive=False),
        "amplitude": Param(0.01, 0.0, 1.0, "tip displacement A (m)", low_inclusive=False),
        "strain": Param("linear", choices=("linear", "green"),
                        doc="the law: linear, or green (StVK: its nonlinearity bounded)"),
        "dt_sweep": Param("reference", choices=("reference", "full"),
                          doc="the reference dt alone (the default run's cost) or the sweep"),
    }
    # cells = 4 (omega_max / omega_h = 181) takes 200 s with implicit Euler: its frequency is
    # in STUDY's eigen-solves
    variants = {"n2": {}, "n2_sweep": {"dt_sweep": "full"},
                "n2_green": {"strain": "green", "amplitude": 3e-4}}
    default_variants = ("n2",)
    quick_variants = ("n2",)

    def _mode(self, p):
        if int(p["cells"]) % 2:
            raise ValueError("bending_frequency.cells must be even (a mid-depth tip node)")
        return first_mode(int(p["cells"]), p["aspect"], p["youngs_modulus"],
                          p["poisson_ratio"], p["density"])

    def omega_eb(self, p) -> float:
        depth = LENGTH / p["aspect"]
        inertia, area = THICKNESS * depth ** 3 / 12, THICKNESS * depth
        return BETA_L ** 2 * np.sqrt(p["youngs_modulus"] * inertia /
                                     (p["density"] * area * LENGTH ** 4))

    def scene(self, p):
        nodes, tris, _, phi, _, _, _ = self._mode(p)
        positions = nodes.copy()
        positions[:, :2] += p["amplitude"] * phi
        material = Material(p["youngs_modulus"], p["poisson_ratio"], p["density"], p["strain"])
        mesh = TriangleMesh(nodes, tris, material, thickness=THICKNESS, plane="stress",
                            pinned=np.flatnonzero(nodes[:, 0] == 0.0), positions=positions)
        return Scene(parts=(mesh,), gravity=(0.0, 0.0, 0.0))

    def bodies(self, p):
        return len(self._mode(p)[0])

    def t_end(self, p):
        return 2 * np.pi / self._mode(p)[2]

    def dts(self, p):
        if p["dt_sweep"] == "reference":
            return [self.reference_dt(p)]
        return [y / self._mode(p)[4] for y in Y_SWEEP]

    def reference_dt(self, p):
        return Y_REFERENCE / self._mode(p)[4]

    def observables(self, p, obs):
        tip = tip_node(self._mode(p)[0], p["aspect"])
        x = np.asarray(obs["x"], float)
        return {"tip_v": x[:, tip, 1] - LENGTH / p["aspect"] / 2}

    def reference(self, p, t):
        return {"tip_v": p["amplitude"] * np.cos(self._mode(p)[2] * np.asarray(t, float))}

    def energy(self, p, obs):
        """Kinetic plus 1/2 u^T K u (J), conserved by the linear flow; green: plus StVK's
        energy instead (one evaluation per sample)."""
        nodes, _, _, _, _, k, m = self._mode(p)
        n = len(obs["x"])
        x = np.asarray(obs["x"], float)
        u = (x - nodes)[..., :2].reshape(n, -1)
        v = np.asarray(obs["v"], float)[..., :2].reshape(n, -1)
        if p["strain"] == "green":
            body = ElasticBody.of(self.scene(p).parts[0])
            return np.array([body.energy(xi[:, :2]) for xi in x]) + 0.5 * (v * v) @ m
        return 0.5 * np.einsum("si,ij,sj->s", u, k, u) + 0.5 * (v * v) @ m

    def nonlinear_bound(self, p) -> float:
        """The green law's geometric nonlinearity at the tip over the period (docstring)."""
        key = tuple(sorted(p.items()))
        cache = self.__dict__.setdefault("_nonlinear", {})
        if key not in cache:
            cache[key] = self._nonlinear_bound(p)
        return cache[key]

    def _nonlinear_bound(self, p) -> float:
        nodes, _, omega, phi, _, k, m = self._mode(p)
        body, free = ElasticBody.of(self.scene(p).parts[0]), np.repeat(nodes[:, 0] > 0.0, 2)
        w2, psi = scipy.linalg.eigh(k[np.ix_(free, free)], np.diag(m[free]))
        u = p["amplitude"] * phi
        plus, minus = (body.forces(nodes[:, :2] + s * u).reshape(-1) + s * (k @ u.reshape(-1))
                       for s in (1.0, -1.0))
        a, b = psi.T @ ((plus + minus) / 2)[free], psi.T @ ((plus - minus) / 2)[free]
        t = self.t_end(p)

        def duhamel(nu):  # max |int_0^t sin(w_j (t - s)) / w_j cos(nu s) ds| per mode
            gap = np.abs(w2 - nu * nu)
            resonant = np.isclose(np.sqrt(w2), nu, rtol=1e-9) & (nu > 0)
            return np.where(resonant, t / (2 * max(nu, 1e-300)), 2 / np.where(gap > 0, gap, 1))

        modal = (np.abs(a) / 2 * (duhamel(0.0) + duhamel(2 * omega))
                 + np.abs(b) / 4 * (3 * duhamel(omega) + duhamel(3 * omega)))
        row = list(np.flatnonzero(free)).index(2 * tip_node(nodes, p["aspect"]) + 1)
        return float(NL_SAFETY * np.abs(psi[row]) @ modal)

    def energy_scale(self, p):
        nodes, _, omega, phi, _, _, m = self._mode(p)
        return float(0.5 * omega ** 2 * p["amplitude"] ** 2 * (phi.reshape(-1) ** 2) @ m)

    def motion_scale(self, p):
        return p["amplitude"]

    def measured_period(self, p, t, tip) -> float:
        """2 x the time between the first two downward and upward zero crossings of the tip
        (linear interpolation between samples); NaN without two."""
        t, tip = np.asarray(t, float), np.asarray(tip, float)
        cross = np.flatnonzero(np.sign(tip[:-1]) * np.sign(tip[1:]) < 0)
        if len(cross) < 2:
            return float("nan")
        at = t[cross] - tip[cross] * (t[cross + 1] - t[cross]) / (tip[cross + 1] - tip[cross])
        return float(2 * (at[1] - at[0]))

    def extra_metrics(self, p, obs, observed, reference):
        period = self.measured_period(p, obs["t"], observed["tip_v"])
        omega_eb = self.omega_eb(p)
        continuum = {a: converged(list(v.values()))[0] for a, v in STUDY.items()}
        return {"period": period, "period_mesh": self.t_end(p),
                "omega_ratio_eb": 2 * np.pi / period / omega_eb,
                "omega_h_ratio_eb": self._mode(p)[2] / omega_eb,
                "continuum_ratio_eb": continuum.get(int(p["aspect"]), float("nan")),
                "beam_ratio_eb": beam_correction(p["aspect"], p["poisson_ratio"])}

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        nodes, _, omega, phi, omega_max, k, m = self._mode(p)
        steps = int(round(self.t_end(p) / dt))
        size = float(np.abs(nodes).max() + p["amplitude"] * np.abs(phi).max())
        dofs = int(np.count_nonzero(nodes[:, 0] > 0)) * 2
        lam_max = float(omega_max ** 2 * m.max())
        accel = np.sqrt(dofs) * ROUNDING_TERMS * EPS * lam_max * size / m.min()
        forced = SAFETY * accel * (steps * dt) ** 2 / 2.0
        state, state_reason = roundoff_tolerance(steps, 0.5 * np.sqrt(3 * len(nodes)) * size)
        growth = 1.0
        if spec_name(integrator) == "explicit_euler":
            growth = (1.0 + (omega_max * dt) ** 2) ** (steps / 2.0)
        k_steps = sample_steps(steps, int(round(self.sample_dt(p) / dt)))
        q, _ = discrete_solution(integrator, -omega * omega, None, 1.0, 0.0, dt, k_steps)
        deviation = p["amplitude"] * float(np.max(np.abs(q[:, 0] - np.cos(omega * k_steps *
                                                                          dt))))
        roundoff = growth * (forced + state)
        nonlinear, nl_reason = 0.0, ""
        if p["strain"] == "green":
            nonlinear = self.nonlinear_bound(p)
            nl_reason = (f"; plus StVK's geometric nonlinearity at A = {p['amplitude']:g} m: "
                         f"{nonlinear:.3g} m (first-order Duhamel bound per mode, x "
                         f"{NL_SAFETY:g}; docstring)")
        return deviation + roundoff + nonlinear, (
            f"{integrator}'s exact discrete solution of q'' = -omega_h^2 q (omega_h = "
            f"{omega:.6g} rad/s, omega_h dt = {omega * dt:.3g}; refsim.expected) errs "
            f"{deviation:.3g} m from A cos(omega_h t) at the {len(k_steps)} samples (max); "
            f"round-off: forces rounded to {ROUNDING_TERMS} eps lambda_max max|x|, moving the "
            f"tip by at most {SAFETY:g} a_r t^2/2 = {forced:.3g} m" + state_reason
            + (f"; times explicit Euler's growth {growth:.3g} on the stiffest mode "
               f"(omega_max dt = {omega_max * dt:.3g})" if growth > 1 else "") + nl_reason)


CASE = BendingFrequency()
