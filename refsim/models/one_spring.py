"""The acceleration of ONE body on ONE spring to a fixed anchor (plus drag and gravity) in
Python floats: the stiff spring and the penalty pendulum, one instance (not a batch).

Why apart from `forces.SpringSet`: on a 3-component state every numpy call costs more than its
arithmetic (a one-spring `SpringSet.forces` plus `ParticleSystem.accel` took 35 us, a third of
the default run's in-house stepping); float arithmetic does the same operations in 3 us. The
operations are those of the numpy path, in its order (x86-64: the same doubles, see below):
|d|^2 = (dx^2 + dz^2) + dy^2 (numpy's einsum over 3 components sums lanes 0 and 2 first:
checked on 2e5 random vectors) and likewise the damping's dv . u; the unit vector is 0 at
|d| = 0; f = -(k (|d| - L0)) u - (c (dv . u)) u - drag v; a = f / m (times 1/m) + g.
On x86-64 the results are the numpy path's doubles (measured); on aarch64 numpy's einsum fuses
multiply-adds, a few ulps apart: tests/models/test_one_spring.py bounds the two paths' difference
in ulps of the terms (16 for the spring).
"""
from __future__ import annotations

import math

import numpy as np


class OneSpringAccel:
    """a(x, v) for flat (3,) x and v of one body on spring 0 of `springs` (to an anchor)."""

    def __init__(self, springs, inv_mass: float, gravity, drag: float):
        self.anchor = tuple(float(a) for a in springs.anchor[0])
        self.k, self.rest = float(springs.stiffness[0]), float(springs.rest[0])
        self.c, self.damped = float(springs.damping[0]), bool(springs.damped)
        self.inv_m, self.drag = float(inv_mass), float(drag)
        self.g = tuple(float(g) for g in gravity)

    @staticmethod
    def applies(springs, nbody: int, rods) -> bool:
        return (rods is None and springs is not None and nbody == 1 and len(springs.body) == 1
                and not springs.any_other)

    def __call__(self, x, v) -> np.ndarray:
        x0, x1, x2 = x.tolist()
        v0, v1, v2 = v.tolist()
        ax, ay, az = self.anchor
        d0, d1, d2 = x0 - ax, x1 - ay, x2 - az
        length = math.sqrt((d0 * d0 + d2 * d2) + d1 * d1)
        if length > 0:
            u0, u1, u2 = d0 / length, d1 / length, d2 / length
        else:
            u0 = u1 = u2 = 0.0
        s = -(self.k * (length - self.rest))
        f0, f1, f2 = s * u0, s * u1, s * u2
        if self.damped:
            cd = self.c * ((v0 * u0 + v2 * u2) + v1 * u1)
            f0, f1, f2 = f0 - cd * u0, f1 - cd * u1, f2 - cd * u2
        if self.drag > 0:
            f0, f1, f2 = f0 - self.drag * v0, f1 - self.drag * v1, f2 - self.drag * v2
        g0, g1, g2 = self.g
        m = self.inv_m
        return np.array((f0 * m + g0, f1 * m + g1, f2 * m + g2))
