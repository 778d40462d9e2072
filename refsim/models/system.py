"""Cartesian particle systems assembled from force terms, in the form the steppers take:
flat state (..., 3 nbody), accel(t, x, v), jacobians(t, x, v), `linear`, `velocity_dependent`.
"""
from __future__ import annotations

import numpy as np

from .forces import SpringSet, drag_jacobian_v
from .joints import RodSet
from .one_rod import OneRodAccel
from .one_spring import OneSpringAccel


class ParticleSystem:
    def __init__(self, masses, gravity, drag=0.0, springs: SpringSet | None = None,
                 rods: RodSet | None = None):
        self.masses = np.asarray(masses, float)
        self.nbody = len(self.masses)
        self.gravity = np.asarray(gravity, float)
        self.drag, self.springs, self.rods = float(drag), springs, rods
        self.has_gravity = bool(np.any(self.gravity))
        self.inv_m = (1.0 / self.masses)[:, None]
        self.weight = self.masses[:, None] * self.gravity  # (nbody, 3)
        self.g_accel = np.broadcast_to(self.gravity, (self.nbody, 3)).copy()
        self.g_flat = self.g_accel.reshape(-1)
        self.g_flat.flags.writeable = False  # shared by every call below: never written
        self.velocity_dependent = bool(
            self.drag > 0 or rods is not None or (springs is not None and springs.damping.any()))
        self.linear = rods is None and (springs is None or springs.linear)
        self.one_spring = (OneSpringAccel(springs, self.inv_m[0, 0], self.gravity, self.drag)
                           if OneSpringAccel.applies(springs, self.nbody, rods) else None)
        if OneRodAccel.applies(springs, self.nbody, rods):  # the same hook: a float path
            self.one_spring = OneRodAccel(rods, self.masses[0], self.weight[0], self.drag)

    def stages(self) -> list[str]:
        out = ["gravity"] if self.has_gravity else []
        if self.drag > 0:
            out.append("drag")
        if self.springs is not None:
            out.append("springs")
        if self.rods is not None:
            out.append("kkt_rods")
        return out

    def forces(self, x, v):
        """Forces other than gravity, (..., nbody, 3), or None when there are none."""
        f = self.springs.forces(x, v) if self.springs is not None else None
        if self.drag > 0:
            f = -self.drag * v if f is None else f - self.drag * v
        return f

    def accel(self, t, x, v):
        if self.one_spring is not None and x.ndim == 1:  # one body, one spring: floats
            return self.one_spring(x, v)
        if self.springs is None and self.rods is None and self.drag == 0 and x.ndim == 1:
            return self.g_flat  # gravity alone on one instance: a constant (free fall)
        shape = x.shape[:-1] + (self.nbody, 3)
        xb, vb = x.reshape(shape), v.reshape(shape)
        f = self.forces(xb, vb)
        if self.rods is not None:
            total = self.weight if f is None else f + self.weight
            if total.shape != shape:  # a batch: the weight broadcast over it
                total = np.broadcast_to(total, shape)
            a = self.rods.project(xb, vb, total, self.masses)
        elif f is None:
            a = np.broadcast_to(self.g_accel, shape)
        else:
            a = f * self.inv_m + self.g_accel
        return a.reshape(x.shape)

    def sparse_force_jacobians(self, t, x, v):
        return sparse_force_jacobians(self, t, x, v)

    def jacobians(self, t, x, v):
        if self.rods is not None:
            return finite_difference_jacobians(self.accel, t, x, v)
        n = x.shape[-1]
        inv_m = np.repeat(1.0 / self.masses, 3)[:, None]
        jx = np.zeros(x.shape[:-1] + (n, n))
        jv = np.zeros_like(jx)
        if self.drag > 0:
            jv = jv + drag_jacobian_v(self.drag, self.masses)
        if self.springs is not None:
            shape = x.shape[:-1] + (self.nbody, 3)
            kx, kv = self.springs.jacobians(x.reshape(shape), v.reshape(shape))
            jx, jv = jx + inv_m * kx, jv + inv_m * kv
        return jx, jv


def sparse_force_jacobians(system, t, x, v):
    """(df/dx, df/dv) of a ParticleSystem's springs and drag as CSR (3n x 3n) FORCE Jacobians
    (not divided by the masses), for one flat state; None when the system has rods (their
    constraint forces have no closed-form sparse Jacobian here)."""
    import scipy.sparse as sp

    from .spring_jacobians import JacobianAssembler
    if system.rods is not None or np.ndim(x) != 1:
        return None
    n = 3 * system.nbody
    if system.springs is not None and getattr(system, "_assembler", None) is None:
        system._assembler = JacobianAssembler(system.springs, system.nbody)  # pattern once
    kx, kv = (system._assembler(x.reshape(-1, 3), v.reshape(-1, 3))
              if system.springs is not None else (sp.csr_matrix((n, n)),) * 2)
    if system.drag > 0:
        kv = kv - system.drag * sp.identity(n, format="csr")
    return kx, kv


def finite_difference_jacobians(accel, t, x, v, rel=1e-6):
    """Central differences of accel in every state component, evaluated as one batch."""
    n = x.shape[-1]
    step = rel * np.maximum(1.0, np.max(np.abs(x)))
    eye = np.eye(n) * step
    xs = x[..., None, :] + np.concatenate([eye, -eye])  # (..., 2n, n)
    vs = np.broadcast_to(v[..., None, :], xs.shape)
    ax = accel(t, xs, vs)
    stepv = rel * np.maximum(1.0, np.max(np.abs(v)))
    vs2 = v[..., None, :] + np.concatenate([np.eye(n), -np.eye(n)]) * stepv
    av = accel(t, np.broadcast_to(x[..., None, :], vs2.shape), vs2)
    jx = np.swapaxes((ax[..., :n, :] - ax[..., n:, :]) / (2 * step), -1, -2)
    jv = np.swapaxes((av[..., :n, :] - av[..., n:, :]) / (2 * stepv), -1, -2)
    return jx, jv


class LinearSystem:
    """a = -K x - C v with constant matrices (per unit mass): the test oscillator of stability
    theory. With K = w^2, C = 0 (1x1) it is the undamped oscillator x'' = -w^2 x."""

    linear = True

    def __init__(self, stiffness, damping=None):
        self.k = np.atleast_2d(np.asarray(stiffness, float))
        self.c = np.zeros_like(self.k) if damping is None else np.atleast_2d(
            np.asarray(damping, float))
        self.velocity_dependent = bool(np.any(self.c))

    def accel(self, t, x, v):
        return -(x @ self.k.T) - (v @ self.c.T)

    def jacobians(self, t, x, v):
        shape = x.shape[:-1] + self.k.shape
        return np.broadcast_to(-self.k, shape), np.broadcast_to(-self.c, shape)
