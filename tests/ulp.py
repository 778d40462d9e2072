"""Bounds in ulps for tests that compare two DIFFERENT computations of the same quantity.

Bit-for-bit equality holds on every machine only where both sides do the same operations in
the same order (tests/BIT_FOR_BIT.md lists where the tests rely on it). Elsewhere numpy's
SIMD loops (einsum's multiply-add is fused on aarch64, not on x86-64's SSE baseline), libm or
SVML transcendentals and BLAS kernels round differently per CPU, so such a test states a bound
in ulps and why it has that size.

One ulp here is eps |scale| (eps = 2^-52): the spacing of doubles at the top of the scale's
binade, between 1 and 2 times np.spacing(scale). The scale defaults to max(|got|, |want|)
element by element (a relative bound); pass the scale of the terms that were summed when the
result is a small difference of larger terms (cancellation), and say so in the reason.
Imported by basename: tests/conftest.py's directory is on sys.path (pytest's prepend import
mode, no __init__.py under tests/).
"""
from __future__ import annotations

import numpy as np

EPS = np.finfo(float).eps


def ulps_apart(got, want, scale=None) -> np.ndarray:
    """|got - want| in units of eps |scale| (elementwise; 0 where both are equal, inf where
    they differ at a zero scale)."""
    got, want = np.asarray(got, float), np.asarray(want, float)
    scale = np.maximum(np.abs(got), np.abs(want)) if scale is None else np.abs(
        np.asarray(scale, float))
    diff = np.abs(got - want)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(diff == 0, 0.0, diff / (EPS * scale))


def assert_ulp(got, want, ulps: float, reason: str, scale=None) -> None:
    """|got - want| <= ulps eps |scale| everywhere (see the module docstring); `reason` says why
    the two sides differ and why by at most that much. NaNs must sit at the same places."""
    got, want = np.asarray(got, float), np.asarray(want, float)
    assert got.shape == want.shape, (got.shape, want.shape)
    nan = np.isnan(got)
    assert np.array_equal(nan, np.isnan(want)), f"NaNs differ: {reason}"
    apart = ulps_apart(np.where(nan, 0.0, got), np.where(nan, 0.0, want), scale)
    worst = float(np.max(apart)) if apart.size else 0.0
    assert worst <= ulps, (f"{worst:.3g} ulps apart, bound {ulps:g} ({reason}); "
                           f"at {np.unravel_index(np.argmax(apart), apart.shape)}")
