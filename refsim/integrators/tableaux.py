"""Butcher tableaux (data) of the explicit Runge-Kutta methods, run by `explicit_rk.ExplicitRK`."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Tableau:
    a: tuple
    b: tuple
    c: tuple
    order: int
    b_low: tuple | None = None  # embedded lower-order weights (error estimate)
    low_order: int | None = None

    def arrays(self):
        return np.array(self.a, float), np.array(self.b, float), np.array(self.c, float)


def rk2_tableau(alpha: float) -> Tableau:
    """The general two-stage, second-order family: alpha=1/2 midpoint, 1 Heun, 2/3 Ralston."""
    if not np.isfinite(alpha) or alpha <= 0 or alpha > 1:
        raise ValueError(f"rk2 alpha must be in (0, 1], got {alpha}")
    w2 = 1.0 / (2.0 * alpha)
    return Tableau(a=((0, 0), (alpha, 0)), b=(1 - w2, w2), c=(0, alpha), order=2)


EULER = Tableau(a=((0,),), b=(1,), c=(0,), order=1)
MIDPOINT = rk2_tableau(0.5)
HEUN = rk2_tableau(1.0)
RK4 = Tableau(
    a=((0, 0, 0, 0), (0.5, 0, 0, 0), (0, 0.5, 0, 0), (0, 0, 1, 0)),
    b=(1 / 6, 1 / 3, 1 / 3, 1 / 6),
    c=(0, 0.5, 0.5, 1),
    order=4,
)
# Dormand & Prince (1980), J. Comp. Appl. Math. 6, 19-26: the 5(4) pair with FSAL 7th stage.
DOPRI5 = Tableau(
    a=(
        (0, 0, 0, 0, 0, 0, 0),
        (1 / 5, 0, 0, 0, 0, 0, 0),
        (3 / 40, 9 / 40, 0, 0, 0, 0, 0),
        (44 / 45, -56 / 15, 32 / 9, 0, 0, 0, 0),
        (19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0, 0, 0),
        (9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0, 0),
        (35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0),
    ),
    b=(35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0),
    c=(0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1, 1),
    order=5,
    b_low=(5179 / 57600, 0, 7571 / 16695, 393 / 640, -92097 / 339200, 187 / 2100, 1 / 40),
    low_order=4,
)
