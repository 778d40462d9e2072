"""Dormand-Prince 5(4) with error control: the explicit RK stepper under a step-size controller."""
from __future__ import annotations

import numpy as np

from .base import StepFailure, plain_addition
from .explicit_rk import ExplicitRK, increment_origin
from .tableaux import DOPRI5


def error_scale(error, x, x1, atol, rtol, plain=True):
    """atol + rtol max(|x|, |x1|) per component. Under a `shift` whose increment has another
    shape than the configuration (a rotation vector for a unit quaternion), one scale per
    configuration, from its largest component."""
    size = np.maximum(np.abs(x), np.abs(x1))
    if not plain and np.shape(size) != np.shape(error):
        size = np.max(size, axis=-1, keepdims=True)
    return atol + rtol * size


class AdaptiveDormandPrince(ExplicitRK):
    """Dormand-Prince 5(4) with error control; each call to `step` lands exactly on t + h.

    `h` is the output interval; inside it, steps are chosen so that the embedded 4th-order error
    estimate satisfies ||err / (atol + rtol max(|y0|, |y1|))||_rms <= 1 (Hairer, Norsett & Wanner,
    Solving ODEs I, II.4), with the standard safety factor 0.9 and growth limits [0.2, 5]. Under
    a system `shift`, the configuration's error is the difference of the two increments (in the
    tangent space), scaled as `error_scale` says.
    """

    family = "adaptive explicit Runge-Kutta"
    adaptive = True

    def __init__(self, rtol=1e-9, atol=1e-12):
        super().__init__("dopri5_adaptive", DOPRI5)
        for label, tol in (("rtol", rtol), ("atol", atol)):
            if not np.isfinite(tol) or tol <= 0:
                raise ValueError(f"dopri5_adaptive {label} must be > 0, got {tol}")
        self.rtol, self.atol = float(rtol), float(atol)
        self._error_weights = [(i, bi - bl) for i, (bi, bl)
                               in enumerate(zip(DOPRI5.b, DOPRI5.b_low)) if bi != bl]
        self.name = f"dopri5_adaptive:{self.rtol:g}"

    def start(self, system, t, x, v, h):
        return (x, v, h)

    def output(self, system, t, state, h):
        return state[0], state[1]

    def _trial(self, system, t, x, v, h, shift):
        kx, kv = self.stages(system, t, x, v, h, shift)
        plain = shift is plain_addition
        x1, v1, ex, ev = increment_origin(shift, x, v), v, 0.0, 0.0
        for i, bi in self._weights:
            x1 = x1 + (h * bi) * kx[i]
            v1 = v1 + (h * bi) * kv[i]
        for i, ei in self._error_weights:
            ex = ex + (h * ei) * kx[i]
            ev = ev + (h * ei) * kv[i]
        x1 = x1 if plain else shift(x, x1)
        sx = error_scale(ex, x, x1, self.atol, self.rtol, plain)
        sv = error_scale(ev, v, v1, self.atol, self.rtol)
        err = np.sqrt(0.5 * (np.mean((ex / sx) ** 2) + np.mean((ev / sv) ** 2)))
        return x1, v1, err

    def _step(self, system, t, state, h, shift):
        x, v, hi = state
        t_end, tc = t + h, t
        while tc < t_end:
            hs = min(hi, t_end - tc)
            if hs <= 1e-14 * max(1.0, abs(tc)):
                raise StepFailure("dopri5_adaptive: step size underflow")
            x1, v1, err = self._trial(system, tc, x, v, hs, shift)
            if not np.isfinite(err):
                raise StepFailure("dopri5_adaptive: non-finite error estimate")
            factor = 5.0 if err == 0 else min(5.0, max(0.2, 0.9 * err ** -0.2))
            if err <= 1.0:
                tc, x, v = tc + hs, x1, v1
                hi = hs * factor if hs == hi else max(hi, hs * factor)
            else:
                hi = hs * factor
        return (x, v, hi)

    def describe(self):
        return {**super().describe(), "rtol": self.rtol, "atol": self.atol}
