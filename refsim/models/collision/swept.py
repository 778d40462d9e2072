"""Swept spheres: the time of impact of two spheres moving at constant velocity, closed form.

With relative position p = c2 - c1, relative velocity v = v2 - v1 and R = r1 + r2, contact is
|p + v t| = R: a t^2 + 2 b t + c = 0 with a = v.v, b = p.v, c = p.p - R^2. The first root,
t = (-b - sqrt(b^2 - a c)) / a, is evaluated as t = c / (-b + sqrt(b^2 - a c)) (the same root,
the two forms' product being c / a): no cancellation between -b and the root when a c is
small against b^2 (contact imminent), where the textbook form loses relative accuracy in t
(its absolute error stays about eps R / |v|).
Cases: c <= 0 (overlapping at t = 0): 0; b >= 0 (not approaching) or b^2 < a c (passing
by): no contact, NaN; a root beyond t_max: NaN.
"""
from __future__ import annotations

import numpy as np


def time_of_impact(c1, v1, r1, c2, v2, r2, t_max) -> np.ndarray:
    """(n,) first contact time in [0, t_max] of each pair, NaN where none."""
    p, v = np.asarray(c2) - np.asarray(c1), np.asarray(v2) - np.asarray(v1)
    reach = np.asarray(r1) + np.asarray(r2)
    a = np.einsum("nk,nk->n", v, v)
    b = np.einsum("nk,nk->n", p, v)
    c = np.einsum("nk,nk->n", p, p) - reach * reach
    disc = b * b - a * c
    with np.errstate(invalid="ignore", divide="ignore"):
        t = c / (np.sqrt(disc) - b)
    hit = (b < 0) & (disc >= 0) & (t <= t_max)
    return np.where(c <= 0, 0.0, np.where(hit, t, np.nan))
