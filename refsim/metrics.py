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
