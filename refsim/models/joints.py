"""Rigid rods (hinge joints) in the three formulations the slides teach.

- generalized coordinates: one angle per rod, theta'' = -(g/L) sin theta - (b/m) theta';
- maximal coordinates with Lagrange multipliers: a KKT solve for (a, lambda) each evaluation,
  with Baumgarte stabilisation C'' + 2 w C' + w^2 C = 0 of C = (|r|^2 - L^2)/2;
- penalty: the rod replaced by a stiff spring (built with `forces.SpringSet`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def hinge_frame(axis, gravity):
    """Unit vectors (d, s) spanning the plane normal to `axis`: d along gravity's in-plane
    component (straight down), s = d x axis. theta is measured from d towards s."""
    axis = np.asarray(axis, float)
    g = np.asarray(gravity, float)
    g_plane = g - axis * (g @ axis)
    if np.linalg.norm(g_plane) > 0:
        d = g_plane / np.linalg.norm(g_plane)
    else:  # no gravity in the plane: any direction normal to the axis
        trial = np.eye(3)[np.argmin(np.abs(axis))]
        d = trial - axis * (trial @ axis)
        d /= np.linalg.norm(d)
    return d, np.cross(d, axis), float(np.linalg.norm(g_plane))


@dataclass(frozen=True)
class HingeSystem:
    """Generalized coordinates: state q = theta, one entry per rod (shape (..., nrod)), or a
    plain float for a single rod (a float operation costs a small fraction of a numpy call on
    a one-element array, and a third of one on a numpy scalar)."""

    g_over_l: np.ndarray
    drag_over_m: np.ndarray
    velocity_dependent: bool = False
    linear: bool = False

    def accel(self, t, q, qd):
        if type(q) is float:  # one rod in plain floats: no numpy call on the hot path
            a = -self.g_over_l * math.sin(q)
            return a - self.drag_over_m * qd if self.velocity_dependent else a
        a = -self.g_over_l * np.sin(q)
        if self.velocity_dependent:
            a = a - self.drag_over_m * qd
        return a

    def jacobians(self, t, q, qd):
        if np.ndim(q) == 0:  # one rod, scalar state
            return -self.g_over_l * math.cos(q), -self.drag_over_m
        ax = np.zeros(q.shape + q.shape[-1:])
        diag = np.arange(q.shape[-1])
        ax[..., diag, diag] = -self.g_over_l * np.cos(q)
        av = np.zeros_like(ax)
        av[..., diag, diag] = -self.drag_over_m
        return ax, av


def hinge_to_cartesian(theta, theta_dot, anchor, length, d, s):
    """Rod angles (..., nrod) to positions and velocities (..., nrod, 3)."""
    c, sn = np.cos(theta)[..., None], np.sin(theta)[..., None]
    L = length[:, None]
    x = anchor + L * (c * d + sn * s)
    v = (L * theta_dot[..., None]) * (-sn * d + c * s)
    return x, v


def cartesian_to_hinge(x, v, anchor, length, d, s):
    r = x - anchor
    theta = np.arctan2(r @ s, r @ d)
    e_theta = -np.sin(theta)[..., None] * d + np.cos(theta)[..., None] * s
    return theta, np.sum(v * e_theta, axis=-1) / length


@dataclass(frozen=True)
class RodSet:
    """Maximal-coordinate rods from fixed anchors, enforced by Lagrange multipliers with
    Baumgarte stabilisation C'' + 2 w C' + w^2 C = 0, C = (|r|^2 - L^2) / 2 per rod."""

    body: np.ndarray
    anchor: np.ndarray
    length: np.ndarray
    baumgarte: float  # w (1/s)

    def __post_init__(self):
        # rod i on body i, one rod per body: x[..., body, :] is x itself (no gather, no copy)
        object.__setattr__(self, "one_per_body",
                           bool(np.array_equal(self.body, np.arange(len(self.body)))))
        object.__setattr__(self, "length_squared", self.length ** 2)

    def constraint(self, x):
        """Rod-length error |x_b - anchor| - L, per rod (..., nrod)."""
        return np.linalg.norm(x[..., self.body, :] - self.anchor, axis=-1) - self.length

    def project(self, x, v, f, masses):
        """Solve the KKT system [[M, J^T], [J, 0]] [a; lam] = [f; rhs] for the accelerations.

        J has one row per rod, r^T in its body's block (r = x_b - anchor), and
        rhs = -|v_b|^2 - 2 w r.v_b - w^2 C. Each rod acts on its own body, so the Schur
        complement J M^-1 J^T is diagonal (|r|^2 / m): eliminating a gives
        lam = (r.f/m - rhs) / (|r|^2/m) and a = (f - lam r) / m, the KKT solution exactly.
        """
        whole = self.one_per_body and x.shape[-2] == len(self.body)
        r = (x if whole else x[..., self.body, :]) - self.anchor
        vb = v if whole else v[..., self.body, :]
        m = masses if whole else masses[self.body]
        rr = _dot(r, r)
        w = self.baumgarte
        rhs = -_dot(vb, vb) - 2.0 * w * _dot(r, vb) - (0.5 * w * w) * (rr - self.length_squared)
        lam = (_dot(r, f if whole else f[..., self.body, :]) / m - rhs) / (rr / m)
        if whole:  # the same arithmetic as the indexed update below, without the copy
            return (f - lam[..., None] * r) / masses[:, None]
        force = f.copy()
        force[..., self.body, :] -= lam[..., None] * r
        return force / masses[:, None]


def _dot(a, b):
    """Row-wise dot product over the last axis (einsum: no temporary, little overhead)."""
    return np.einsum("...i,...i->...", a, b)
