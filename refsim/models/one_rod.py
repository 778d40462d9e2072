"""The acceleration of ONE body on ONE rigid rod (maximal coordinates, KKT with Baumgarte
stabilisation, `joints.RodSet.project`) in Python floats: the KKT pendulum, one instance.

Why apart from `RodSet`: on a 3-component state the numpy calls cost more than their
arithmetic (`RodSet.project` and its caller took ~90 us an evaluation); floats do the same
operations, in the same order, in a few us (x86-64: the same doubles). Dot products
sum as numpy's einsum does over 3 components, (a0 b0 + a2 b2) + a1 b1 (see one_spring.py).
With r = x - anchor, f the applied force (weight m g and drag -c v):
  rhs = -|v|^2 - 2 w r.v - (w^2 / 2) (|r|^2 - L^2),  lam = (r.f / m - rhs) / (|r|^2 / m),
  a = (f - lam r) / m.
tests/models/test_one_spring.py bounds its difference from the numpy path in ulps (20): numpy's
einsum fuses multiply-adds on aarch64.
"""
from __future__ import annotations

import numpy as np


def _dot(a0, a1, a2, b0, b1, b2):
    return (a0 * b0 + a2 * b2) + a1 * b1


class OneRodAccel:
    """a(x, v) for flat (3,) x and v of one body on rod 0 of `rods`."""

    def __init__(self, rods, mass: float, weight, drag: float):
        self.anchor = tuple(float(a) for a in rods.anchor[0])
        self.length_squared = float(rods.length_squared[0])
        self.w, self.m, self.drag = float(rods.baumgarte), float(mass), float(drag)
        self.weight = tuple(float(f) for f in weight)

    @staticmethod
    def applies(springs, nbody: int, rods) -> bool:
        return springs is None and rods is not None and nbody == 1 and len(rods.body) == 1

    def __call__(self, x, v) -> np.ndarray:
        x0, x1, x2 = x.tolist()
        v0, v1, v2 = v.tolist()
        a0, a1, a2 = self.anchor
        r0, r1, r2 = x0 - a0, x1 - a1, x2 - a2
        f0, f1, f2 = self.weight
        if self.drag > 0:  # forces() = -drag v, then + weight
            f0, f1, f2 = -self.drag * v0 + f0, -self.drag * v1 + f1, -self.drag * v2 + f2
        m, w = self.m, self.w
        rr = _dot(r0, r1, r2, r0, r1, r2)
        rhs = (-_dot(v0, v1, v2, v0, v1, v2) - 2.0 * w * _dot(r0, r1, r2, v0, v1, v2)
               - (0.5 * w * w) * (rr - self.length_squared))
        lam = (_dot(r0, r1, r2, f0, f1, f2) / m - rhs) / (rr / m)
        return np.array(((f0 - lam * r0) / m, (f1 - lam * r1) / m, (f2 - lam * r2) / m))
