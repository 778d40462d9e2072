"""Shared orbit helpers of the gravity cases (kepler, figure_eight): the exact two-body
solution (Kepler's equation by vectorised Newton), conserved quantities of stacked
observations, drifts, the measured period, and the orbit tolerance.

Two-body solution (Murray & Dermott, Solar System Dynamics, 1999, sec. 2.4): relative orbit
r = x_2 - x_1 with semi-major axis a, eccentricity e, mean motion n = sqrt(G M / a^3), started
at periapsis on the +x axis moving +y. Mean anomaly M = n t; eccentric anomaly E from
Kepler's equation E - e sin E = M; r = a (cos E - e, sqrt(1 - e^2) sin E, 0),
dr/dt = a n / (1 - e cos E) (-sin E, sqrt(1 - e^2) cos E, 0). Each body about the centre of
mass (at rest at the origin): x_1 = -m_2/M r, x_2 = m_1/M r. Period T = 2 pi a^1.5 / sqrt(G M).
"""
from __future__ import annotations

import numpy as np

from refsim.case import order_tolerance
from refsim.models.nbody_gravity import angular_momentum, runge_lenz, total_energy

KEPLER_MAX_NEWTON = 50


def solve_kepler(mean_anomaly, e):
    """E with E - e sin E = M, vectorised Newton from E = M + e sin M (Danby's start is not
    needed below e = 0.99: Newton on this convex-concave function converges from M + e sin M
    for e < 1; every E converges to round-off, |residual| <= 4 eps max(1, |M|))."""
    if not 0.0 <= e < 1.0:
        raise ValueError(f"eccentricity must be in [0, 1), got {e}")
    m = np.asarray(mean_anomaly, float)
    ecc = m + e * np.sin(m)
    for _ in range(KEPLER_MAX_NEWTON):
        step = (ecc - e * np.sin(ecc) - m) / (1.0 - e * np.cos(ecc))
        ecc = ecc - step
        if np.all(np.abs(step) <= 4 * np.finfo(float).eps * np.maximum(1.0, np.abs(m))):
            break
    return ecc


def kepler_residual(ecc, mean_anomaly, e):
    """E - e sin E - M: Kepler's equation's residual (round-off at a solution)."""
    return np.asarray(ecc) - e * np.sin(ecc) - np.asarray(mean_anomaly)


def kepler_period(a, G, total_mass):
    return 2.0 * np.pi * a ** 1.5 / np.sqrt(G * total_mass)


def relative_orbit(t, a, e, G, total_mass):
    """(r, w) of the relative orbit at times t, each (T, 3)."""
    n = np.sqrt(G * total_mass / a ** 3)
    ecc = solve_kepler(n * np.asarray(t, float), e)
    cos_e, sin_e, root = np.cos(ecc), np.sin(ecc), np.sqrt(1.0 - e * e)
    zero = np.zeros_like(ecc)
    r = a * np.stack([cos_e - e, root * sin_e, zero], axis=-1)
    rate = (a * n / (1.0 - e * cos_e))[..., None]
    w = rate * np.stack([-sin_e, root * cos_e, zero], axis=-1)
    return r, w


def two_body_state(t, a, e, G, masses):
    """(x, v) of both bodies about their centre of mass at rest at the origin, (T, 2, 3)."""
    m1, m2 = masses
    total = m1 + m2
    r, w = relative_orbit(t, a, e, G, total)
    share = np.array([-m2 / total, m1 / total])[:, None]
    return share * r[..., None, :], share * w[..., None, :]


def invariants_of(obs, masses, G):
    """E, P, L (and the eccentricity vector for two bodies) of stacked observations."""
    x, v = np.asarray(obs["x"], float), np.asarray(obs["v"], float)
    out = {"energy": total_energy(x, v, masses, G),
           "momentum": np.einsum("i,tik->tk", np.asarray(masses, float), v),
           "angular_momentum": angular_momentum(x, v, masses)}
    if x.shape[-2] == 2:
        out["runge_lenz"] = runge_lenz(x, v, masses, G)
    return out


def vector_drift(values, scale):
    """max_t |V(t) - V(0)| / scale of a (T, 3) conserved vector."""
    values = np.asarray(values, float)
    return float(np.max(np.linalg.norm(values - values[0], axis=-1)) / scale)


def polar_angle(r):
    """Unwrapped polar angle (rad) of (T, 3) relative positions in the x-y plane."""
    return np.unwrap(np.arctan2(r[:, 1], r[:, 0]))


def measured_period(t, r, w):
    """2 t_k / k at the last crossing of the polar angle through k pi, k odd (k half turns from
    periapsis: an apoapsis passage, where the angle moves slowest and smoothest), the crossing
    found by cubic Hermite interpolation of the unwrapped angle on
    its bracketing samples (angle and rate (r x w)_z / |r|^2 at both: error O(dt_s^4));
    NaN before the first half turn."""
    t = np.asarray(t, float)
    theta = polar_angle(r) - np.arctan2(r[0, 1], r[0, 0])
    rate = np.cross(r, w)[:, 2] / np.einsum("tk,tk->t", r, r)
    k = int(np.floor(abs(theta[-1]) / np.pi))
    k -= 1 - k % 2  # the last odd k: an apoapsis
    if k < 1:
        return float("nan")
    target = np.sign(theta[-1]) * k * np.pi
    i = int(np.nonzero(np.sign(theta[-1]) * (theta - target) >= 0)[0][0])
    if i == 0:
        return float("nan")
    h = t[i] - t[i - 1]
    s = np.clip((target - theta[i - 1]) / (theta[i] - theta[i - 1]), 0.0, 1.0)
    for _ in range(20):  # Newton on the Hermite cubic in s in [0, 1]
        h00, h10 = 2 * s ** 3 - 3 * s ** 2 + 1, s ** 3 - 2 * s ** 2 + s
        h01, h11 = -2 * s ** 3 + 3 * s ** 2, s ** 3 - s ** 2
        value = (h00 * theta[i - 1] + h10 * h * rate[i - 1] + h01 * theta[i]
                 + h11 * h * rate[i] - target)
        slope = ((6 * s ** 2 - 6 * s) * theta[i - 1] + (3 * s ** 2 - 4 * s + 1) * h * rate[i - 1]
                 + (-6 * s ** 2 + 6 * s) * theta[i] + (3 * s ** 2 - 2 * s) * h * rate[i])
        s = s - value / slope
    return float(2.0 * (t[i - 1] + s * h) / k)


def orbit_tolerance(scale, rate_max, t, dt, order, symplectic, mean_rate):
    """(tol, reason): `order_tolerance` with the fastest angular rate of the orbit as its
    frequency (the periapsis rate bounds every local rate, so y = rate_max dt bounds the step's
    phase increment everywhere), times 1 + 1.5 n t for a non-symplectic method, n =
    `mean_rate` = 2 pi / T the mean motion: its energy error changes the period, T ~ |E|^-1.5
    (dlnT/dlnE = -1.5, Kepler's third law; the same scaling holds for every orbit of a
    potential homogeneous of degree -1, x -> l x, t -> l^1.5 t, E -> E / l), so the orbit's
    phase, which advances at n, lags by 1.5 n t times the relative energy error."""
    y, omega_t = rate_max * dt, rate_max * t
    tol = order_tolerance(scale, omega_t, y, order, symplectic)
    if symplectic:
        # the shape term doubled: the modified orbit starts off by a velocity error of at most
        # y^p / 2 of w r (symplectic Euler: a half kick h a / 2, radial on a circle), and on an
        # orbit a radial velocity error dv displaces the body along-track by up to 4 dv / n
        # (Hill / Clohessy-Wiltshire: 2 dv / n (1 - cos n t)): 2 y^p S, not y^p S. Measured on
        # the circle at T/400..T/3200: 1.963, 1.980, 1.989, 1.994 y S (tends to 2 y S)
        tol = tol + scale * y ** order
        return tol, (f"order {order}, symplectic: S (2 (w dt)^p + w t (w dt)^q), q = 2 "
                     f"ceil(p/2), w = periapsis angular rate {rate_max:.3g} rad/s, S = "
                     f"{scale:.3g} (see order_tolerance; the factor 2: a radial velocity error "
                     "dv displaces an orbit along-track by up to 4 dv / n, Clohessy-Wiltshire)")
    growth = 1.0 + 1.5 * mean_rate * t
    return tol * growth, (f"order {order}: S expm1(w t (w dt)^p) (see order_tolerance), "
                          f"w = periapsis angular rate {rate_max:.3g} rad/s, S = {scale:.3g}, "
                          f"times 1 + 1.5 n t = {growth:.3g} (n = 2 pi / T, dlnT/dlnE = -1.5: "
                          "an energy error changes the period and the phase lags with t)")
