"""Shared orbit helpers of the gravity cases (kepler, figure_eight): the exact two-body
solution (Kepler's equation by vectorised Newton), conserved quantities of stacked
observations, drifts, the measured period, and the orbit bound: Henrici's linearised global
error of the named method (`linearised_error`), times one safety factor 2.

Two-body solution (Murray & Dermott, Solar System Dynamics, 1999, sec. 2.4): relative orbit
r = x_2 - x_1 with semi-major axis a, eccentricity e, mean motion n = sqrt(G M / a^3), started
at periapsis on the +x axis moving +y. Mean anomaly M = n t; eccentric anomaly E from
Kepler's equation E - e sin E = M; r = a (cos E - e, sqrt(1 - e^2) sin E, 0),
dr/dt = a n / (1 - e cos E) (-sin E, sqrt(1 - e^2) cos E, 0). Each body about the centre of
mass (at rest at the origin): x_1 = -m_2/M r, x_2 = m_1/M r. Period T = 2 pi a^1.5 / sqrt(G M).
"""
from __future__ import annotations

import numpy as np

from refsim.integrators import StepFailure, get_integrator
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


def sampled_steps(t_end, sample_dt, dt) -> np.ndarray:
    """The step counts a job observes at (stride as refsim/run/job.py computes it)."""
    steps = int(round(t_end / dt))
    stride = max(1, int(round(sample_dt / dt)))
    return np.unique(np.append(np.arange(0, steps + 1, stride), steps))


def _variational_steps(jac0, jac_mid, jac1, h):
    """RK4 step matrices, stacked over the steps, of the variational equation
    e' = [[0, I], [J(t), 0]] e along the exact orbit (J = da/dx at the step's start, middle and
    end): its error per step is O((w h)^5) of e, far below the propagated error itself."""
    count, m = jac0.shape[0], jac0.shape[-1]
    eye, zero, big = np.broadcast_to(np.eye(m), (count, m, m)), np.zeros((count, m, m)), \
        np.eye(2 * m)
    first, middle, last = (np.block([[zero, eye], [j, zero]]) for j in (jac0, jac_mid, jac1))
    k2 = middle @ (big + 0.5 * h * first)
    k3 = middle @ (big + 0.5 * h * k2)
    k4 = last @ (big + h * k3)
    return big + h / 6.0 * (first + 2.0 * k2 + 2.0 * k3 + k4)


def linearised_error(integrator, system, exact, jacobian, dt, sampled) -> float:
    """max over the sampled steps of |e_k| (positions, all bodies) of Henrici's linearised
    global error of the NAMED method (Henrici, Discrete Variable Methods in ODEs, 1962,
    sec. 3.4; Hairer, Norsett & Wanner I, 1993, sec. II.3):

        e_{k+1} = P_k e_k + d_{k+1},   e_0 = 0,

    d_{k+1} = Phi_h(z(t_k)) - z(t_{k+1}) the method's local error: one step of the named method
    (its definition, `refsim.integrators.get_integrator`, all steps at once as a batch) from
    the EXACT state z(t_k) = (x, v) = `exact(t)`, and P_k the exact flow's linearisation over
    the step (`_variational_steps`, J = `jacobian(x)` = da/dx). Exact for a linear system; on
    an orbit it leaves out terms O(|e|^2 / a) (the error's own effect on the force). An
    adaptive method (dopri5_adaptive) steps each output interval from the exact state under its
    own controller (local error held to rtol per step), so d is what its controller allows."""
    steps, stepper = int(sampled[-1]), get_integrator(integrator)
    keep = np.zeros(steps + 1, bool)
    keep[np.asarray(sampled, int)] = True
    e, worst = None, 0.0
    for first in range(0, steps, CHUNK):  # bounded memory: CHUNK steps' matrices at a time
        t = np.arange(first, min(first + CHUNK, steps) + 1) * dt
        x, v = exact(t)
        local = _local_errors(stepper, system, x, v, dt)
        x_mid, _ = exact(t[:-1] + 0.5 * dt)
        flow = _variational_steps(jacobian(x[:-1]), jacobian(x_mid), jacobian(x[1:]), dt)
        m = x.shape[-1]
        e = np.zeros(2 * m) if e is None else e
        for k in range(len(local)):
            e = flow[k] @ e + local[k]
            if keep[first + k + 1]:
                worst = max(worst, float(np.linalg.norm(e[:m])))
    return worst


CHUNK = 4096


def _local_errors(stepper, system, x, v, dt):
    """One step of `stepper` from each exact state (x[k], v[k]) minus (x[k+1], v[k+1])."""
    try:  # every step at once, as a batch (not an adaptive one: one step size for all)
        if getattr(stepper, "adaptive", False):
            raise ValueError("adaptive: its controller chooses each interval's own steps")
        state = stepper.start(system, 0.0, x[:-1], v[:-1], dt)
        x1, v1 = stepper.output(system, 0.0, stepper.step(system, 0.0, state, dt), dt)
    except (ValueError, np.linalg.LinAlgError, StepFailure):  # a stepper without batches
        ends = [stepper.output(system, 0.0, stepper.step(
            system, 0.0, stepper.start(system, 0.0, x[k], v[k], dt), dt), dt)
            for k in range(len(x) - 1)]
        x1, v1 = np.array([e[0] for e in ends]), np.array([e[1] for e in ends])
    return np.concatenate([x1 - x[1:], v1 - v[1:]], axis=-1)


SAFETY = 2.0  # the one safety factor of the orbit bound (see orbit_bound)


def orbit_bound(integrator, system, exact, jacobian, dt, sampled):
    """(bound, reason) of a fixed-step method: SAFETY x `linearised_error`. The factor 2 is
    for the terms the linearisation leaves out (O(|e|^2), the error's own effect on the
    force): on the Kepler and figure-eight orbits the real error is 0.73..1.04 of the
    linearised one wherever the bound resolves the orbit (0.73: dopri5_adaptive, whose
    controller carries its step size across intervals in a run)."""
    linear = linearised_error(integrator, system, exact, jacobian, dt, sampled)
    return SAFETY * linear, (
        f"{SAFETY:g} x {linear:.4g} m: Henrici's linearised global error of {integrator} "
        "(its local error from the exact state at every step, one step of the method's "
        "definition (an adaptive one: each output interval under its own controller, which "
        "holds the local error to rtol per step), propagated by the exact orbit's variational "
        f"equation), max over the samples; safety factor {SAFETY:g} for the second-order terms "
        "the linearisation leaves out (measured: the real error is 0.73..1.04 of the "
        "linearised one on the Kepler and figure-eight orbits)")
