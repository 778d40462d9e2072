"""Error norms, drifts, measured convergence order and the stability-limit search."""
from __future__ import annotations

import numpy as np


def error_norms(err: np.ndarray) -> dict:
    """err: error of the compared observable at every sample (already a norm per sample)."""
    err = np.asarray(err, float)
    return {"err_max": float(np.max(err)), "err_final": float(err[-1]),
            "err_rms": float(np.sqrt(np.mean(err ** 2)))}


def energy_drift(energy, reference_energy, scale: float) -> float:
    """max |E(t) - E_ref(t)| / scale; E_ref is E(0) for conservative cases, the exact energy
    for dissipative ones; scale is |E(0)| or the case's documented scale."""
    if energy is None:
        return float("nan")
    return float(np.max(np.abs(np.asarray(energy) - reference_energy)) / scale)


def convergence_order(dts, errs, floor: float, ceiling: float) -> tuple[float, int]:
    """Least-squares slope of log err against log dt over the asymptotic range.

    Points with err <= floor (round-off) or err >= ceiling (pre-asymptotic or unstable) are
    dropped. Returns (slope, points used); NaN with fewer than two points.
    """
    dts, errs = np.asarray(dts, float), np.asarray(errs, float)
    keep = np.isfinite(errs) & (errs > floor) & (errs < ceiling)
    if np.count_nonzero(keep) < 2:
        return float("nan"), int(np.count_nonzero(keep))
    slope = np.polyfit(np.log(dts[keep]), np.log(errs[keep]), 1)[0]
    return float(slope), int(np.count_nonzero(keep))


def spectral_radius(matrix: np.ndarray) -> np.ndarray:
    return np.max(np.abs(np.linalg.eigvals(matrix)), axis=-1)


def bisect_limit(is_stable, lo: float, hi: float, tol: float = 1e-6) -> float:
    """Largest y in [lo, hi] with is_stable(y), assuming stable below and unstable above."""
    if not is_stable(lo):
        return lo
    if is_stable(hi):
        return float("inf")
    while hi - lo > tol * max(1.0, lo):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if is_stable(mid) else (lo, mid)
    return lo


def step_matrix(stepper, system, state_template, h) -> np.ndarray:
    """The matrix of one step of `stepper` on a linear `system`, in the stepper's own state
    (e.g. (x_n, x_{n-1}) for position Verlet): the state components are stacked into one
    vector and each unit vector is stepped, all as one batch."""
    sizes = [np.shape(s)[-1] for s in state_template]
    total = sum(sizes)
    basis = np.eye(total)
    parts = np.split(basis, np.cumsum(sizes)[:-1], axis=1)
    stepped = stepper.step(system, 0.0, tuple(parts), h)
    return np.concatenate([np.asarray(s) for s in stepped], axis=1).T


def oscillator_stable(stepper, y: float, omega: float = 1.0, slack: float = 1e-12) -> bool:
    """Stable on x'' = -omega^2 x at y = omega h: spectral radius of the step matrix <= 1."""
    from refsim.models.system import LinearSystem
    system = LinearSystem([[omega * omega]])
    h = y / omega
    template = stepper.start(system, 0.0, np.zeros(1), np.zeros(1), h)
    radius = spectral_radius(step_matrix(stepper, system, template, h))
    return bool(np.all(np.isfinite(radius)) and radius <= 1.0 + slack)
