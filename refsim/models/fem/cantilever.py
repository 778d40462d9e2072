"""The Timoshenko cantilever in plane stress (Timoshenko & Goodier, Theory of Elasticity,
3rd ed. 1970, sec. 21), a P1 test with an exact solution: the beam [0, L] x [-D/2, D/2] of
unit thickness, the exact displacement imposed on the edge x = 0 and the exact parabolic shear
traction t_y = P / (2 I) (D^2/4 - y^2) (total P) on the edge x = L; I = D^3 / 12.

    u = -P y / (6 E I) [(6 L - 3 x) x + (2 + nu)(y^2 - D^2/4)]
    v = P / (6 E I) [3 nu y^2 (L - x) + (4 + 5 nu) D^2 x / 4 + (3 L - x) x^2]
    sigma_xx = -P (L - x) y / I, sigma_yy = 0, tau_xy = P / (2 I) (D^2/4 - y^2)

v(L, 0) = P L^3 / (3 E I) + (4 + 5 nu) P D^2 L / (24 E I) = 0.0089000 m for L = 48, D = 12,
E = 3e7, nu = 0.3, P = 1000. P1 converges as O(h^2) in the L2 norm of the displacement error
and O(h) in the energy norm; the norms here integrate the exact field by a Gauss rule on each
triangle (Duffy's collapsed square, exact for polynomials of degree 2 n - 2).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .meshes import rectangle_triangles


@dataclass(frozen=True)
class Cantilever:
    length: float = 48.0
    depth: float = 12.0
    youngs_modulus: float = 3.0e7
    poisson_ratio: float = 0.3
    load: float = 1000.0

    @property
    def inertia(self) -> float:
        return self.depth ** 3 / 12.0

    def tip_deflection(self) -> float:
        p, e, i, nu = self.load, self.youngs_modulus, self.inertia, self.poisson_ratio
        return (p * self.length ** 3 / (3 * e * i)
                + (4 + 5 * nu) * p * self.depth ** 2 * self.length / (24 * e * i))

    def displacement(self, x, y):
        """(u, v) of the exact solution at points x, y (arrays)."""
        p, e, i, nu = self.load, self.youngs_modulus, self.inertia, self.poisson_ratio
        ell, d2 = self.length, self.depth ** 2
        u = -p * y / (6 * e * i) * ((6 * ell - 3 * x) * x + (2 + nu) * (y * y - d2 / 4))
        v = p / (6 * e * i) * (3 * nu * y * y * (ell - x) + (4 + 5 * nu) * d2 * x / 4
                               + (3 * ell - x) * x * x)
        return np.stack([u, v], -1)

    def strain(self, x, y):
        """(..., 2, 2) small strain of the exact solution."""
        p, e, i, nu = self.load, self.youngs_modulus, self.inertia, self.poisson_ratio
        exx = -p * (self.length - x) * y / (e * i)
        eyy = -nu * exx
        gamma = p * (1 + nu) / (e * i) * (self.depth ** 2 / 4 - y * y)
        return np.stack([np.stack([exx, gamma / 2], -1), np.stack([gamma / 2, eyy], -1)], -2)

    def shear_traction(self, y):
        return self.load / (2 * self.inertia) * (self.depth ** 2 / 4 - y * y)

    def mesh(self, nx, ny):
        """Nodes (n, 3), triangles of an nx x ny grid of the beam (y from -D/2)."""
        return rectangle_triangles(nx, ny, self.length, self.depth,
                                   origin=(0.0, -self.depth / 2, 0.0))

    def boundary(self, nodes):
        """(fixed (n, 2) bool, x0 (n, 2) with the exact field on x = 0, loads (n, 2)): the
        consistent nodal loads of the parabolic shear on x = L, integral t_y phi_a dy exactly
        (3-point Gauss on each edge segment: the integrand is cubic)."""
        xy = nodes[:, :2]
        clamped = xy[:, 0] == 0.0
        fixed = np.repeat(clamped[:, None], 2, 1)
        x0 = xy.copy()
        x0[clamped] += self.displacement(xy[clamped, 0], xy[clamped, 1])
        edge = np.flatnonzero(xy[:, 0] == self.length)
        edge = edge[np.argsort(xy[edge, 1])]
        y0, y1 = xy[edge[:-1], 1], xy[edge[1:], 1]
        s, w = np.polynomial.legendre.leggauss(3)
        s, w = (s + 1) / 2, w / 2
        y = y0[:, None] + (y1 - y0)[:, None] * s  # (segments, 3)
        t = self.shear_traction(y) * w * (y1 - y0)[:, None]
        loads = np.zeros_like(xy)
        np.add.at(loads[:, 1], edge[:-1], t @ (1 - s))  # a few dozen edge nodes, once
        np.add.at(loads[:, 1], edge[1:], t @ s)
        return fixed, x0, loads


def triangle_rule(n=5):
    """(points (q, 2) in the reference triangle, weights (q,) summing to 1/2): Gauss-Legendre
    on the square collapsed by Duffy's map (u, v) -> (u, v (1 - u)); exact for polynomials of
    degree <= 2 n - 2."""
    s, w = np.polynomial.legendre.leggauss(n)
    s, w = (s + 1) / 2, w / 2
    u, v = np.meshgrid(s, s, indexing="ij")
    wu, wv = np.meshgrid(w, w, indexing="ij")
    points = np.stack([u.reshape(-1), (v * (1 - u)).reshape(-1)], -1)
    return points, (wu * wv * (1 - u)).reshape(-1)


def error_norms(beam: Cantilever, body, x, n=5):
    """(L2 norm of u - u_h, energy norm sqrt(int (eps - eps_h) : C : (eps - eps_h))) of the
    P1 solution x (n, 2) (positions) on `body` (an ElasticBody of the beam, plane stress)."""
    el = body.elements
    points, weights = triangle_rule(n)
    corners = el.rest[el.cells]  # (m, 3, 2)
    phi = np.stack([1 - points.sum(1), points[:, 0], points[:, 1]], 1)  # (q, 3)
    where = np.einsum("qa,mai->mqi", phi, corners)
    u_h = np.einsum("qa,mai->mqi", phi, (x - el.rest)[el.cells])
    jac = 2 * el.volume / el.thickness  # |det Dm| for the rule's reference area 1/2
    diff = beam.displacement(where[..., 0], where[..., 1]) - u_h
    l2 = np.sqrt(np.sum(jac[:, None] * weights * np.sum(diff ** 2, -1)))
    grad_u = el.deformation_gradient(x) - np.eye(2)  # du_i/dX_j = F - I
    eps_h = 0.5 * (grad_u + np.swapaxes(grad_u, 1, 2))
    de = beam.strain(where[..., 0], where[..., 1]) - eps_h[:, None]
    e, nu = beam.youngs_modulus, beam.poisson_ratio
    mu, lam = e / (2 * (1 + nu)), e * nu / (1 - nu * nu)
    density = 2 * mu * np.sum(de * de, (-2, -1)) + lam * np.trace(de, axis1=-2, axis2=-1) ** 2
    energy = np.sqrt(np.sum(jac[:, None] * weights * density))
    return float(l2), float(energy)
