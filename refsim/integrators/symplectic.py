"""Symplectic Euler (kick-drift and drift-kick), velocity Verlet, Stormer-Verlet and leapfrog.

Every drift moves the configuration through the system's update `shift(x, dx)` (plain addition
x + dx when the system has none: the same arithmetic as before the hook, bit for bit).
"""
from __future__ import annotations

from .base import Integrator


class SymplecticEulerKD(Integrator):
    """Kick then drift: v1 = v + h a(x, v); x1 = x + h v1 (semi-implicit Euler of most engines)."""

    name, order, family, symplectic = "symplectic_euler", 1, "symplectic Euler", True

    def _step(self, system, t, state, h, shift):
        x, v = state
        v = v + h * system.accel(t, x, v)
        return (shift(x, h * v), v)


class SymplecticEulerDK(Integrator):
    """Drift then kick: x1 = x + h v; v1 = v + h a(x1, v)."""

    name, order, family, symplectic = "symplectic_euler_dk", 1, "symplectic Euler", True

    def _step(self, system, t, state, h, shift):
        x, v = state
        x = shift(x, h * v)
        return (x, v + h * system.accel(t + h, x, v))


class VelocityVerlet(Integrator):
    """Half kick, drift, half kick; the acceleration is carried to the next step (1 eval/step).

    With velocity-dependent forces the closing half kick is corrected once with the new
    velocity, which keeps second order (the plain explicit form drops to first).
    """

    name, order, family, symplectic = "velocity_verlet", 2, "Verlet", True

    def start(self, system, t, x, v, h):
        return (x, v, system.accel(t, x, v))

    def _step(self, system, t, state, h, shift):
        x, v, a = state
        vh = v + (0.5 * h) * a
        x = shift(x, h * vh)
        a = system.accel(t + h, x, vh)
        v = vh + (0.5 * h) * a
        if system.velocity_dependent:
            a = system.accel(t + h, x, v)
            v = vh + (0.5 * h) * a
        return (x, v, a)


class StormerVerlet(Integrator):
    """Position (Stormer) Verlet: x_{n+1} = 2 x_n - x_{n-1} + h^2 a(x_n), no velocities.

    Run in its summed form (Hairer, Lubich & Wanner, Geometric Numerical Integration, I.1.4):
    state (x_n, d_n = x_n - x_{n-1}), d_{n+1} = d_n + h^2 a(x_n), x_{n+1} = x_n + d_{n+1}; the
    same recurrence with far less round-off than 2 x_n - x_{n-1}. Started with
    d_0 = h v0 - h^2/2 a0 so that x_1 is the Taylor step; output velocity
    v_n = d_n / h + h/2 a(x_n), which equals velocity Verlet's. Under a system `shift`, d is a
    tangent increment and x_{n+1} = shift(x_n, d_{n+1}).
    """

    name, order, family, symplectic = "stormer_verlet", 2, "Verlet", True

    def start(self, system, t, x, v, h):
        return (x, h * v - (0.5 * h * h) * system.accel(t, x, v))

    def _velocity(self, system, t, x, d, h):
        vb = d / h
        v = vb + (0.5 * h) * system.accel(t, x, vb)
        if system.velocity_dependent:
            v = vb + (0.5 * h) * system.accel(t, x, v)
        return v

    def _step(self, system, t, state, h, shift):
        x, d = state
        v = self._velocity(system, t, x, d, h) if system.velocity_dependent else d / h
        d = d + (h * h) * system.accel(t, x, v)
        return (shift(x, d), d)

    def output(self, system, t, state, h):
        x, d = state
        return x, self._velocity(system, t, x, d, h)


class Leapfrog(Integrator):
    """Staggered velocities: v_{n+1/2} = v_{n-1/2} + h a(x_n); x_{n+1} = x_n + h v_{n+1/2}.

    State (x_n, v_{n-1/2}); output synchronises v_n = v_{n-1/2} + h/2 a(x_n).
    """

    name, order, family, symplectic = "leapfrog", 2, "Verlet", True

    def start(self, system, t, x, v, h):
        return (x, v - (0.5 * h) * system.accel(t, x, v))

    def _sync(self, system, t, x, vm, h):
        v = vm + (0.5 * h) * system.accel(t, x, vm)
        if system.velocity_dependent:
            v = vm + (0.5 * h) * system.accel(t, x, v)
        return v

    def _step(self, system, t, state, h, shift):
        x, vm = state
        v = self._sync(system, t, x, vm, h) if system.velocity_dependent else vm
        vm = vm + h * system.accel(t, x, v)
        return (shift(x, h * vm), vm)

    def output(self, system, t, state, h):
        x, vm = state
        return x, self._sync(system, t, x, vm, h)
