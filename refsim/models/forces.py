"""Forces on point masses (springs, linear drag), with their Jacobians.

Positions and velocities have shape (..., nbody, 3); Jacobians are (..., 3 nbody, 3 nbody).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def drag_jacobian_v(drag, masses) -> np.ndarray:
    return np.diag(np.repeat(-drag / masses, 3))


@dataclass(frozen=True)
class SpringSet:
    """Springs as arrays: body index, other body (-1 for a fixed anchor), anchor, k, L0, c."""

    body: np.ndarray
    other: np.ndarray
    anchor: np.ndarray
    stiffness: np.ndarray
    rest: np.ndarray
    damping: np.ndarray

    @classmethod
    def from_scene(cls, springs):
        return cls(
            body=np.array([s.body for s in springs], int),
            other=np.array([-1 if s.other is None else s.other for s in springs], int),
            anchor=np.array([s.anchor for s in springs], float).reshape(-1, 3),
            stiffness=np.array([s.stiffness for s in springs], float),
            rest=np.array([s.rest_length for s in springs], float),
            damping=np.array([s.damping for s in springs], float),
        )

    @property
    def linear(self) -> bool:
        """Zero rest length and no damping: f = -k d is linear in x."""
        return bool(np.all(self.rest == 0) and np.all(self.damping == 0))

    def __post_init__(self):
        has_other = self.other >= 0
        ends = np.concatenate([self.body, self.other[has_other]])
        fixed = {"has_other": has_other, "any_other": bool(has_other.any()),
                 "unique_ends": len(np.unique(ends)) == len(ends),
                 # per-call constants of forces(), shaped once (each saves a numpy call there)
                 "k_column": self.stiffness[:, None], "rest_column": self.rest[:, None],
                 "c_column": self.damping[:, None], "damped": bool(self.damping.any()),
                 # every body i on its own spring i to an anchor: forces are the spring forces
                 "one_per_body": bool(not has_other.any()
                                      and np.array_equal(self.body, np.arange(len(self.body))))}
        for name, value in fixed.items():
            object.__setattr__(self, name, value)

    def _ends(self, x, v):
        if self.one_per_body and x.shape[-2] == len(self.body):  # x[..., body, :] is x itself
            return x - self.anchor, v
        if not self.any_other:  # every spring to a fixed anchor
            return x[..., self.body, :] - self.anchor, v[..., self.body, :]
        has_other, safe = self.has_other[:, None], np.maximum(self.other, 0)
        other_x = np.where(has_other, x[..., safe, :], self.anchor)
        other_v = np.where(has_other, v[..., safe, :], 0.0)
        return x[..., self.body, :] - other_x, v[..., self.body, :] - other_v

    def _axis(self, d):
        """(|d|, d / |d|), the unit vector 0 where |d| = 0 (d / inf = 0: one division, the same
        quotients as dividing where |d| > 0)."""
        length = np.sqrt(np.einsum("...i,...i->...", d, d))[..., None]
        return length, d / np.where(length > 0, length, np.inf)

    def forces(self, x, v) -> np.ndarray:
        """Force on every body: -k (|d| - L0) u - c (dv . u) u, equal and opposite on `other`."""
        d, dv = self._ends(x, v)
        length, unit = self._axis(d)
        f = -(self.k_column * (length - self.rest_column)) * unit
        if self.damped:
            f = f - self.c_column * np.einsum("...i,...i->...", dv, unit)[..., None] * unit
        if self.one_per_body and f.shape == x.shape:  # f is a fresh array: it is the forces
            return f
        out = np.zeros_like(x)
        if self.unique_ends:  # no body shared by two spring ends: plain indexed writes
            out[..., self.body, :] = f
            if self.any_other:
                out[..., self.other[self.has_other], :] = -f[..., self.has_other, :]
            return out
        _add_batched(out, self.body, f)
        if self.any_other:
            _add_batched(out, self.other[self.has_other], -f[..., self.has_other, :])
        return out

    def jacobians(self, x, v):
        """(df/dx, df/dv), each (..., 3n, 3n). The x-derivative of the damping direction is
        left out: exact when the motion stays along the spring axis (as in the cases here)."""
        d, _ = self._ends(x, v)
        length, unit = self._axis(d)
        uu = unit[..., :, None] * unit[..., None, :]
        eye = np.eye(3)
        ratio = np.divide(self.rest[:, None], length, out=np.zeros_like(length),
                          where=length > 0)[..., None]
        kx = -self.stiffness[:, None, None] * ((1 - ratio) * eye + ratio * uu)
        kv = -self.damping[:, None, None] * uu
        n = x.shape[-2]
        jx = np.zeros(x.shape[:-2] + (3 * n, 3 * n))
        jv = np.zeros_like(jx)
        for s, (i, j) in enumerate(zip(self.body, self.other)):
            for jac, block in ((jx, kx[..., s, :, :]), (jv, kv[..., s, :, :])):
                _add_block(jac, i, i, block)
                if j >= 0:
                    _add_block(jac, j, j, block)
                    _add_block(jac, i, j, -block)
                    _add_block(jac, j, i, -block)
        return jx, jv


def _add_batched(out, index, values):
    """out[..., index, :] += values, with repeated indices summed."""
    np.add.at(np.moveaxis(out, -2, 0), index, np.moveaxis(values, -2, 0))


def _add_block(jac, i, j, block):
    jac[..., 3 * i:3 * i + 3, 3 * j:3 * j + 3] += block
