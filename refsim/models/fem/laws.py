"""Hyperelastic laws of the P1 finite elements (slide 001's strain measures, and Neo-Hookean),
vectorised over elements: energy density Psi(F) (J/m^3), first Piola-Kirchhoff stress
P = dPsi/dF (Pa) and its directional derivative dP = (dP/dF) : dF in closed form.

F is (m, d, d); a law works in its own dimension d (2 for plane stress, 3 for tetrahedra and,
through `PlaneStrain`, for triangles in plane strain). mu and lam are the law's Lame
parameters (`lame_parameters`). Sources: Bonet & Wood, Nonlinear Continuum Mechanics for
Finite Element Analysis (2008), ch. 5-6; Sifakis & Barbic, FEM Simulation of 3D Deformable
Solids (SIGGRAPH 2012 course notes), sec. 3-5; Smith, de Goes & Kim, Stable Neo-Hookean Flesh
Simulation (ACM TOG 2018). Summary and slips: docs/models.md#fem-elements-and-strain-measures.

- "linear" (Cauchy small strain as slide 001 prints it): eps = 1/2 (F + F^T) - I,
  Psi = mu eps:eps + lam/2 tr(eps)^2, P = sigma = 2 mu eps + lam tr(eps) I. Not rotation
  invariant: a rigid rotation by theta gives eps = (cos theta - 1) I in 2D ((cos theta - 1)
  (I - n n^T) about an axis n in 3D) and a spurious force.
- "green" (St Venant-Kirchhoff): E = 1/2 (F^T F - I), S = 2 mu E + lam tr(E) I, P = F S,
  Psi = mu E:E + lam/2 tr(E)^2.
- "corotated": F = R S by polar decomposition (R from the SVD F = U Sigma V^T, R = U V^T, the
  rotation-variant SVD: the last singular value takes the sign of det F, so R is a rotation
  even for an inverted element); slide 001's eps = 1/2 (F~ + F~^T) - I with F~ = R^T F = S,
  Psi = mu |S - I|^2 + lam/2 tr(S - I)^2 = mu sum (s_i - 1)^2 + lam/2 (sum s_i - d)^2,
  P = R sigma(S - I) = 2 mu (F - R) + lam tr(S - I) R (Sifakis & Barbic eq. 3.4). The stress
  finds R without a per-element SVD (refsim.models.fem.polar: the 2D closed form; in 3D and
  plane strain, where det F > 0, the same R by Newton's iteration or the 2D closed form, else
  the SVD); energy and tangent take `_polar` (3D: the SVD).
- "neo_hookean": the stable Neo-Hookean energy of Smith et al. (2018, eq. 14) in d dimensions,
  the energy pybullet's deformable world uses (btDeformableNeoHookeanForce, d = 3):
  Psi = mu/2 (I_C - d) + lam/2 (J - alpha)^2 - mu/2 log(I_C + 1) - Psi(I),
  I_C = |F|^2, J = det F, alpha = 1 + d mu / ((d + 1) lam) (3D: 1 + 3 mu / (4 lam), so that
  P(I) = 0); P = mu (1 - 1/(I_C + 1)) F + lam (J - alpha) cof F, cof F = J F^-T. Its mu, lam
  are Smith et al.'s reparametrisation of the material's Lame pair (mu_L, lam_L), chosen so
  that the law linearises to linear elasticity at F = I: mu = (d + 1)/d mu_L,
  lam = lam_L + (1 - 2/(d (d + 1))) mu_L (3D: 4/3 mu_L and lam_L + 5/6 mu_L). Psi(I) is
  subtracted so that the rest energy is 0 (pybullet keeps it; forces are the same).
"""
from __future__ import annotations

import copy

import numpy as np

from .polar import plane_corotated_stress, spatial_corotated_stress
from .tensors import (by_components, cofactor, cofactor_differential, components, ddot, identity,
                      new_like, rotation_variant_svd, trace, trace_minus, transposed)

LAW_NAMES = ("linear", "green", "corotated", "neo_hookean")


def lame_parameters(youngs_modulus, poisson_ratio, plane_stress=False):
    """(mu, lam) of E, nu: 3D (and plane strain) mu = E / (2 (1 + nu)),
    lam = E nu / ((1 + nu)(1 - 2 nu)); plane stress lam* = E nu / (1 - nu^2) = 2 mu lam /
    (lam + 2 mu) (the 2D law of a thin sheet, sigma_zz = 0: exact for small strain, the usual
    membrane convention for the large-strain laws, as MuJoCo's flex uses)."""
    e, nu = float(youngs_modulus), float(poisson_ratio)
    mu = e / (2.0 * (1.0 + nu))
    lam = e * nu / (1.0 - nu * nu) if plane_stress else e * nu / ((1.0 + nu) * (1.0 - 2 * nu))
    return mu, lam


def neo_hookean_parameters(mu_lame, lam_lame, d):
    """(mu, lam, alpha) of the stable Neo-Hookean law from the Lame pair (module docstring)."""
    mu = (d + 1) / d * mu_lame
    lam = lam_lame + (1.0 - 2.0 / (d * (d + 1))) * mu_lame
    if not lam > 0:
        raise ValueError(f"material.poisson_ratio: the stable Neo-Hookean law needs lam = "
                         f"lam_L + (1 - 2/(d(d+1))) mu_L > 0 (in plane stress nu > -1/2), "
                         f"got lam = {lam:g}")
    return mu, lam, 1.0 + d * mu / ((d + 1) * lam)


class Law:
    """A hyperelastic law: name, dimension d, Lame parameters (mu, lam); subclasses give
    energy_density(F), stress(F) and differential(F, dF) (dF of shape (m, k, d, d): k
    directions per element; returns (m, k, d, d))."""

    name = ""

    def __init__(self, mu, lam, d):
        self.mu, self.lam, self.d = float(mu), float(lam), int(d)

    def tangent(self, f):
        """dP/dF as (m, d, d, d, d): C[e, i, j, k, l] = dP_ij / dF_kl."""
        d = self.d
        units = np.eye(d * d).reshape(d * d, d, d)
        dp = self.differential(f, np.broadcast_to(units, (len(f),) + units.shape))
        return np.moveaxis(dp.reshape(len(f), d, d, d, d), (1, 2), (3, 4))

    def describe(self) -> dict:
        return {"law": self.name, "dimension": self.d, "mu": self.mu, "lam": self.lam}


class Linear(Law):
    name = "linear"

    def strain(self, f):
        return 0.5 * (f + transposed(f)) - identity(f.shape[-1])

    def energy_density(self, f):
        eps = self.strain(f)
        return self.mu * ddot(eps, eps) + 0.5 * self.lam * trace(eps) ** 2

    def stress(self, f):
        """2 mu eps + lam tr(eps) I entry by entry (one pass per operation over the elements;
        the operations of the matrix form, eps_kk = F_kk - 1 and eps_ij = (F_ij + F_ji) / 2)."""
        d, fc = self.d, components(f)
        p, pc = new_like(f)
        two_mu, lt = 2.0 * self.mu, self.lam * trace_minus(fc, d, 1.0)
        for i in range(d):
            np.multiply(fc[i, i] - 1.0, two_mu, out=pc[i, i])
            pc[i, i] += lt
            for j in range(i + 1, d):
                np.multiply(0.5 * (fc[i, j] + fc[j, i]), two_mu, out=pc[i, j])
                pc[j, i] = pc[i, j]
        return p

    def differential(self, f, df):
        return self.mu * (df + transposed(df)) + self.lam * trace(df)[..., None, None] * identity(self.d)

    def tangent(self, f):
        """The constant C_ijkl = mu (d_ik d_jl + d_il d_jk) + lam d_ij d_kl for every element
        (a read-only broadcast of one (d, d, d, d) array: the same values as the directional
        derivatives' route, without computing them per element)."""
        one = super().tangent(np.eye(self.d)[None])[0]
        return np.broadcast_to(one, (len(f),) + one.shape)


class Green(Law):
    name = "green"

    def strain(self, f):
        return 0.5 * (transposed(f) @ f - identity(f.shape[-1]))

    def _pk2(self, e):
        return 2.0 * self.mu * e + self.lam * trace(e)[..., None, None] * identity(self.d)

    def energy_density(self, f):
        e = self.strain(f)
        return self.mu * ddot(e, e) + 0.5 * self.lam * trace(e) ** 2

    def stress(self, f):
        """P = F S, S = 2 mu E + lam tr(E) I, E = (F^T F - I) / 2, entry by entry (one pass per
        operation over the elements, the matrix form's sums in its order)."""
        d, fc = self.d, components(f)
        e = np.empty((d, d) + f.shape[:-2])
        for i in range(d):
            for j in range(i, d):  # E is symmetric
                c = fc[0, i] * fc[0, j]
                for k in range(1, d):
                    c += fc[k, i] * fc[k, j]
                if i == j:
                    c -= 1.0
                e[i, j] = c
                e[i, j] *= 0.5
        two_mu, lt = 2.0 * self.mu, self.lam * trace_minus(e, d, 0.0)
        for i in range(d):
            e[i, i] *= two_mu
            e[i, i] += lt
            for j in range(i + 1, d):
                e[i, j] *= two_mu
                e[j, i] = e[i, j]
        p, pc = new_like(f)
        tmp = np.empty(f.shape[:-2])
        for i in range(d):
            for j in range(d):
                np.multiply(fc[i, 0], e[0, j], out=pc[i, j])
                for k in range(1, d):
                    pc[i, j] += np.multiply(fc[i, k], e[k, j], out=tmp)
        return p

    def differential(self, f, df):
        f = f[:, None]
        de = 0.5 * (transposed(df) @ f + transposed(f) @ df)
        return df @ self._pk2(self.strain(f)) + f @ self._pk2(de)


class Corotated(Law):
    name = "corotated"

    def _polar(self, f):
        """(R, s, Vt): the rotation maximising tr(R^T F) (the rotation-variant polar factor)
        and the signed singular values; Vt is None in 2D, where they are closed forms:
        R = [[c, -s], [s, c]], (c, s) = (F00 + F11, F10 - F01) / r, tr(R^T F) = r = s1 + s2,
        s1 - s2 = |(F00 - F11, F10 + F01)| (R = I where r = 0: no rotation is preferred).
        Elementwise, 30x faster than a batched SVD at 10^4 triangles; 3D: the SVD."""
        if self.d != 2:
            u, s, vt = rotation_variant_svd(f)
            return u @ vt, s, vt
        x, y = f[..., 0, 0] + f[..., 1, 1], f[..., 1, 0] - f[..., 0, 1]
        r = np.hypot(x, y)
        safe = np.where(r > 0.0, r, 1.0)
        c, s = np.where(r > 0.0, x / safe, 1.0), np.where(r > 0.0, y / safe, 0.0)
        rot = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
        q = np.hypot(f[..., 0, 0] - f[..., 1, 1], f[..., 1, 0] + f[..., 0, 1])
        return rot, np.stack([0.5 * (r + q), 0.5 * (r - q)], -1), None

    def energy_density(self, f):
        _, s, _ = self._polar(f)
        return self.mu * np.sum((s - 1.0) ** 2, -1) + 0.5 * self.lam * (np.sum(s, -1)
                                                                        - self.d) ** 2

    def stress(self, f):
        """2D: `plane_corotated_stress`; 3D: `spatial_corotated_stress` (Newton's polar
        iteration, the SVD where F is inverted)."""
        if self.d == 2:
            return plane_corotated_stress(f, self.mu, self.lam)
        return spatial_corotated_stress(f, self.mu, self.lam, self._svd_stress)

    def _svd_stress(self, f):
        """P = 2 mu (F - R) + lam (tr S - d) R with R and S's singular values by the SVD."""
        r, s, _ = self._polar(f)
        return 2.0 * self.mu * (f - r) + self.lam * (np.sum(s, -1) - self.d)[..., None, None] * r

    def rotation_differential(self, r, s, vt, df):
        """dR = R W, W skew with W S + S W = A - A^T, A = R^T dF (Sifakis & Barbic sec. 5):
        2D w = (A - A^T)_10 / tr S; 3D axial(W) = (tr S I - S)^-1 axial(A - A^T), with
        tr S I - S = V diag(tr S - s_i) V^T."""
        a = transposed(r) @ df
        k = a - transposed(a)
        if self.d == 2:
            w = k[..., 1, 0] / np.sum(s, -1)
            zero = np.zeros_like(w)
            skew = np.stack([np.stack([zero, -w], -1), np.stack([w, zero], -1)], -2)
        else:
            axial = np.stack([k[..., 2, 1], k[..., 0, 2], k[..., 1, 0]], -1)
            inv = 1.0 / (np.sum(s, -1)[..., None] - s)
            w = np.einsum("...ji,...j,...jk,...k->...i", vt, inv, vt, axial)
            zero = np.zeros_like(w[..., 0])
            skew = np.stack([np.stack([zero, -w[..., 2], w[..., 1]], -1),
                             np.stack([w[..., 2], zero, -w[..., 0]], -1),
                             np.stack([-w[..., 1], w[..., 0], zero], -1)], -2)
        return r @ skew

    def differential(self, f, df):
        r, s, vt = (None if a is None else a[:, None] for a in self._polar(f))
        dr = self.rotation_differential(r, s, vt, df)
        stretch = (np.sum(s, -1) - self.d)[..., None, None]
        return (2.0 * self.mu * df + self.lam * trace(transposed(r) @ df)[..., None, None] * r
                + (self.lam * stretch - 2.0 * self.mu) * dr)


class NeoHookean(Law):
    name = "neo_hookean"
    padded = 0.0  # F_zz^2 of a plane-strain law's pad (PlaneStrain), added to I_C

    def __init__(self, mu_lame, lam_lame, d):
        mu, lam, self.alpha = neo_hookean_parameters(mu_lame, lam_lame, d)
        super().__init__(mu, lam, d)
        self.rest_energy = 0.5 * lam * (1.0 - self.alpha) ** 2 - 0.5 * mu * np.log(d + 1.0)

    def energy_density(self, f):
        ic, j = ddot(f, f), np.linalg.det(f)
        return (0.5 * self.mu * (ic - self.d) + 0.5 * self.lam * (j - self.alpha) ** 2
                - 0.5 * self.mu * np.log1p(ic) - self.rest_energy)

    def stress(self, f):
        """P = a F + b cof F, a = mu I_C / (I_C + 1) (= mu (1 - 1 / (I_C + 1))), b = lam (J -
        alpha), entry by entry: cof F's entries as products of F's (2D: +-F entries; 3D: the
        2 x 2 minors, cyclic), J = sum_k F_0k cof_0k."""
        d, fc = self.d, components(f)
        ic = fc[0, 0] * fc[0, 0]
        for i in range(d):
            for j in range(d):
                if i or j:
                    ic += fc[i, j] * fc[i, j]
        if self.padded:
            ic += self.padded
        cof = np.empty((d, d) + f.shape[:-2])
        if d == 2:
            cof[0, 0], cof[1, 1] = fc[1, 1], fc[0, 0]
            np.negative(fc[1, 0], out=cof[0, 1])
            np.negative(fc[0, 1], out=cof[1, 0])
        else:
            for i in range(3):
                i1, i2 = (i + 1) % 3, (i + 2) % 3
                for j in range(3):
                    j1, j2 = (j + 1) % 3, (j + 2) % 3
                    np.multiply(fc[i1, j1], fc[i2, j2], out=cof[i, j])
                    cof[i, j] -= fc[i1, j2] * fc[i2, j1]
        b = fc[0, 0] * cof[0, 0]
        for k in range(1, d):
            b += fc[0, k] * cof[0, k]
        b -= self.alpha
        b *= self.lam
        a = ic * self.mu
        ic += 1.0
        a /= ic
        p, pc = new_like(f)
        for i in range(d):
            for j in range(d):
                np.multiply(fc[i, j], a, out=pc[i, j])
                cof[i, j] *= b
                pc[i, j] += cof[i, j]
        return p

    def differential(self, f, df):
        f = f[:, None]
        ic, j, cof = ddot(f, f), np.linalg.det(f), cofactor(f)
        scale = lambda a: a[..., None, None]  # noqa: E731
        return (scale(self.mu * (1.0 - 1.0 / (ic + 1.0))) * df
                + scale(2.0 * self.mu * ddot(f, df) / (ic + 1.0) ** 2) * f
                + scale(self.lam * ddot(cof, df)) * cof
                + scale(self.lam * (j - self.alpha)) * cofactor_differential(f, df))


class PlaneStrain(Law):
    """A 3D law on triangles in plane strain: F padded to diag(F, 1) (eps_zz = 0), P and dP/dF
    their in-plane blocks. Exact: the 3D energy of a prism deformed in its plane."""

    def __init__(self, law3d: Law):
        self.law, self.name = law3d, law3d.name
        super().__init__(law3d.mu, law3d.lam, 2)
        self._in_plane = None  # the 3D law's entry-by-entry stress over the in-plane entries
        if law3d.name in ("linear", "green", "neo_hookean"):
            self._in_plane = copy.copy(law3d)
            self._in_plane.d = 2
            self._in_plane.padded = 1.0  # Neo-Hookean's I_C keeps its F_zz^2 = 1

    @staticmethod
    def _pad(f, one):
        out = np.zeros(f.shape[:-2] + (3, 3))
        out[..., :2, :2] = f
        out[..., 2, 2] = one
        return out

    def energy_density(self, f):
        return self.law.energy_density(self._pad(f, 1.0))

    def stress(self, f):
        """The 3D law's stress at diag(F, 1), its in-plane block: for linear, green and
        neo_hookean the law's entry-by-entry formula over the in-plane entries (the padded
        entries, F_zz = 1 and zeros, only add exact zeros there: the same values), corotated
        `_corotated_stress`; any other law on F padded with component-wise memory."""
        if self._in_plane is not None:
            return self._in_plane.stress(f)
        if self.name == "corotated":
            return self._corotated_stress(f)
        pad = by_components(3, f.shape[:-2])
        pc = components(pad)
        pc[:2, 2], pc[2, :2], pc[2, 2] = 0.0, 0.0, 1.0
        pc[:2, :2] = components(f)
        return self.law.stress(pad)[..., :2, :2]

    def _corotated_stress(self, f):
        """Where det F > 0 the polar decomposition diag(F, 1) = diag(R, 1) diag(S, 1) is the
        unique one (S positive definite), so the 3D law's stress is the 2D closed form with the
        3D mu and lam (tr S + 1 - 3 = r - 2); elsewhere (inverted or collapsed elements, where
        the rotation-variant SVD may flip the z axis) the 3D law's SVD on those elements."""
        p = plane_corotated_stress(f, self.mu, self.lam)
        fc = components(f)
        bad = fc[0, 0] * fc[1, 1] - fc[0, 1] * fc[1, 0] <= 0.0
        if bad.any():
            p[bad] = self.law.stress(self._pad(f[bad], 1.0))[..., :2, :2]
        return p

    def differential(self, f, df):
        return self.law.differential(self._pad(f, 1.0), self._pad(df, 0.0))[..., :2, :2]

    def tangent(self, f):
        """The 3D law's tangent at diag(F, 1), its in-plane block (F_zz and the out-of-plane
        entries held: their derivatives drop out)."""
        return self.law.tangent(self._pad(f, 1.0))[..., :2, :2, :2, :2]

    def describe(self) -> dict:
        return {**self.law.describe(), "plane": "strain (3D law, F_zz = 1)", "dimension": 2}


_CLASSES = {"linear": Linear, "green": Green, "corotated": Corotated, "neo_hookean": NeoHookean}


def make_law(strain, youngs_modulus, poisson_ratio, dim, plane="stress") -> Law:
    """The law of a material's strain measure for elements of dimension `dim` (2: triangles
    in plane `plane` "stress" or "strain"; 3: tetrahedra)."""
    if strain not in _CLASSES:
        raise ValueError(f"material.strain must be one of {list(LAW_NAMES)}, got {strain!r}")
    if dim == 2 and plane == "strain":
        return PlaneStrain(make_law(strain, youngs_modulus, poisson_ratio, 3))
    mu, lam = lame_parameters(youngs_modulus, poisson_ratio, plane_stress=dim == 2)
    return _CLASSES[strain](mu, lam, dim)


def law_of(material, dim, plane="stress") -> Law:
    return make_law(material.strain, material.youngs_modulus, material.poisson_ratio, dim,
                    plane)
