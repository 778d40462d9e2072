"""Von Mises plasticity on the FEM strain measures, with the permanent (plastic) strain stored
per element (slide 001 prints plasticity only as F = Fe Fp, without a yield rule; this is
refsim's choice, stated here).

Kinematics: an additive split of the law's own strain measure, eps_e = eps(F) - eps_p, with
eps = 1/2 (F + F^T) - I ("linear"), the Green strain E ("green") or S - I with F = R S
("corotated": the plastic strain lives in the rotated frame, as in Muller & Gross 2004); in
3D (tetrahedra, and triangles in plane strain through F padded to diag(F, 1): eps_zz = 0 while
the plastic eps_p,zz is free). Stress sigma = lam tr(eps_e) I + 2 mu eps_e (Hooke on the
elastic part), turned into the first Piola stress as the elastic law does: P = sigma
(linear), F sigma (green: sigma is the second Piola stress, exactly dPsi/dF), R sigma
(corotated: slide 001's f = Q sigma n, exact while eps_p commutes with S, e.g. in uniaxial
states; otherwise the slides' convention, not an exact gradient).

Yield rule: von Mises with linear isotropic hardening, f = |s| - sqrt(2/3) (sigma_y + H a) <= 0,
s = dev sigma, a the equivalent plastic strain (a = eps_p,xx in uniaxial tension, so H is the
slope of stress against plastic strain there; H = 0: ideal plasticity, MuJoCo 4's flex
`yield`). Return mapping: the radial return of Simo & Hughes, Computational Inelasticity
(1998), Box 3.2: trial s_tr = 2 mu dev(eps - eps_p), f_tr = |s_tr| - sqrt(2/3)(sigma_y + H a);
where f_tr > 0, dgamma = f_tr / (2 mu + 2 H / 3), n = s_tr / |s_tr|, eps_p += dgamma n,
a += sqrt(2/3) dgamma. Exact for proportional loading with linear hardening, in one step.

Uniaxial tension to a strain eps (of the law's measure) past yield, then unloading to zero
stress, leaves the permanent strain eps_p,xx = (E eps - sigma_y) / (E + H) and lateral
-eps_p,xx / 2 (plastic flow keeps volume).

`VonMises` is a law (stress, energy_density, tangent) evaluated from the COMMITTED plastic
state; `commit(F)` makes the return of the current F permanent (after a converged static
step or an accepted time step). Its tangent is the elastic law's (a modified Newton: the
static solve converges linearly where elements yield).
"""
from __future__ import annotations

import numpy as np

from .laws import PlaneStrain, rotation_variant_svd

ROOT_2_3 = np.sqrt(2.0 / 3.0)


class VonMises:
    """Von Mises plasticity around an elastic law ("linear", "green" or "corotated"; d = 3, or
    2 in plane strain) for m elements; state eps_p (m, 3, 3) and a (m,)."""

    def __init__(self, law, plasticity, m):
        plane_strain = isinstance(law, PlaneStrain)
        base = law.law if plane_strain else law
        if base.d != 3:
            raise ValueError("mesh.plane: plasticity runs on tetrahedra or plane strain "
                             "(plane stress needs the plane-stress return of Simo & Taylor "
                             "1986, not built)")
        if base.name not in ("linear", "green", "corotated"):
            raise ValueError(f"material.strain: plasticity is built for 'linear', 'green' and "
                             f"'corotated' (an additive split of the strain), got "
                             f"{base.name!r}")
        self.elastic, self.base, self.plane_strain = law, base, plane_strain
        self.name, self.d, self.mu, self.lam = base.name, law.d, base.mu, base.lam
        self.yield_stress = float(plasticity.yield_stress)
        self.hardening = float(plasticity.hardening)
        self.plastic_strain = np.zeros((int(m), 3, 3))
        self.equivalent = np.zeros(int(m))

    def _padded(self, f):
        return PlaneStrain._pad(f, 1.0) if self.plane_strain else f

    def _strain(self, f):
        """(eps (m, 3, 3), the factor that turns sigma into P: I, F or R)."""
        if self.name == "linear":
            return 0.5 * (f + np.swapaxes(f, 1, 2)) - np.eye(3), None
        if self.name == "green":
            return 0.5 * (np.swapaxes(f, 1, 2) @ f - np.eye(3)), f
        u, s, vt = rotation_variant_svd(f)
        return np.swapaxes(vt, 1, 2) @ (s[:, :, None] * vt) - np.eye(3), u @ vt

    def _return(self, f):
        """(sigma, elastic strain, eps_p, a, the P factor) after the radial return from the
        committed state."""
        eps, factor = self._strain(f)
        trial = eps - self.plastic_strain
        dev = trial - np.trace(trial, axis1=1, axis2=2)[:, None, None] / 3.0 * np.eye(3)
        s_norm = 2.0 * self.mu * np.linalg.norm(dev, axis=(1, 2))
        over = s_norm - ROOT_2_3 * (self.yield_stress + self.hardening * self.equivalent)
        dgamma = np.where(over > 0, over, 0.0) / (2.0 * self.mu + 2.0 * self.hardening / 3.0)
        unit = np.divide(2.0 * self.mu * dev, s_norm[:, None, None], out=np.zeros_like(dev),
                         where=s_norm[:, None, None] > 0)
        elastic = trial - dgamma[:, None, None] * unit
        sigma = (self.lam * np.trace(elastic, axis1=1, axis2=2)[:, None, None] * np.eye(3)
                 + 2.0 * self.mu * elastic)
        return (sigma, elastic, self.plastic_strain + dgamma[:, None, None] * unit,
                self.equivalent + ROOT_2_3 * dgamma, factor)

    def stress(self, f):
        sigma, _, _, _, factor = self._return(self._padded(f))
        p = sigma if factor is None else factor @ sigma
        return p[:, :2, :2] if self.plane_strain else p

    def energy_density(self, f):
        """Stored elastic energy mu eps_e : eps_e + lam/2 tr(eps_e)^2 after the return."""
        _, e, _, _, _ = self._return(self._padded(f))
        return self.mu * np.sum(e * e, (1, 2)) + 0.5 * self.lam * np.trace(e, axis1=1,
                                                                          axis2=2) ** 2

    def tangent(self, f):
        return self.elastic.tangent(f)

    def commit(self, f):
        """Make the return at F (m, d, d) permanent: the plastic strain and a are stored."""
        _, _, self.plastic_strain, self.equivalent, _ = self._return(self._padded(f))

    def describe(self) -> dict:
        return {**self.elastic.describe(), "plasticity": "von Mises, radial return",
                "yield_stress": self.yield_stress, "hardening": self.hardening}
