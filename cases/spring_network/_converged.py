"""A converged in-house reference for a spring network without a closed form: refsim's RK4 on
refsim.models.spring_network.NetworkSystem at a small step h, checked by a second run at 2h
(Richardson: RK4's global error at h is |x_h - x_2h| / (2^4 - 1) to leading order), stored
every `stride` steps as (t, x, v) of every node and read at any time by cubic Hermite
interpolation of (x, v) (exact at the stored times; between them it errs by at most
h_s^4 max|x''''| / 384, h_s the storage interval).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from refsim.integrators import get_integrator
from refsim.models.spring_network import NetworkSystem, kinetic_energy, network_potential

RK4_RICHARDSON = 2.0 ** 4 - 1.0  # x_2h - x_h = (2^4 - 1) C h^4 + ...


@dataclass(frozen=True)
class ConvergedRun:
    t: np.ndarray        # (s,) stored times
    x: np.ndarray        # (s, n, 3) every node
    v: np.ndarray        # (s, n, 3)
    h: float             # the reference step
    richardson: np.ndarray  # (s,) estimated error of x at h: mean over nodes, m
    energy: np.ndarray   # (s,) kinetic + potential, J
    accel: np.ndarray    # (s, n, 3) accelerations, m/s^2

    def derivative_norm(self, order: int) -> float:
        """max over time of the mean over nodes of |d^order x / dt^order| (order >= 2): the
        acceleration, differenced (order - 2) times over the stored samples (central
        differences of spacing h_s: relative error O((w h_s)^2) for a motion of frequency w)."""
        spacing = self.t[1] - self.t[0]
        d = self.accel
        for _ in range(order - 2):
            d = np.gradient(d, spacing, axis=0, edge_order=2)
        return float(np.max(np.mean(np.linalg.norm(d, axis=2), axis=1)))

    def derivative_series(self, order: int) -> np.ndarray:
        """(s,) mean over nodes of |d^order x / dt^order| at the stored times (see
        `derivative_norm`)."""
        spacing = self.t[1] - self.t[0]
        d = self.accel
        for _ in range(order - 2):
            d = np.gradient(d, spacing, axis=0, edge_order=2)
        return np.mean(np.linalg.norm(d, axis=2), axis=1)

    def derivative_integral(self, order: int) -> float:
        """int_0^t_end mean_i |x_i^(order)| dt by the trapezoid rule over the stored times:
        the sum over steps of h |x^(order)(t_k)| (a sum of local errors) in the limit."""
        series = self.derivative_series(order)
        spacing = self.t[1] - self.t[0]
        return float(spacing * (np.sum(series) - 0.5 * (series[0] + series[-1])))

    def at(self, t) -> tuple[np.ndarray, np.ndarray]:
        """(x, v) at times t by cubic Hermite interpolation between stored samples."""
        t = np.asarray(t, float)
        spacing = self.t[1] - self.t[0]
        u = t / spacing
        nearest = np.round(u)
        on_sample = np.abs(u - nearest) < 1e-9  # a stored time: no interpolation
        k = np.clip(np.where(on_sample, nearest, np.floor(u)).astype(int), 0, len(self.t) - 1)
        s = np.where(on_sample, 0.0, np.clip(u - k, 0.0, 1.0))[:, None, None]
        k1 = np.minimum(k + 1, len(self.t) - 1)
        x0, x1, v0, v1 = self.x[k], self.x[k1], self.v[k], self.v[k1]
        h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
        h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
        x = h00 * x0 + h10 * spacing * v0 + h01 * x1 + h11 * spacing * v1
        dh00, dh10 = (6 * s**2 - 6 * s) / spacing, 3 * s**2 - 4 * s + 1
        dh01, dh11 = (-6 * s**2 + 6 * s) / spacing, 3 * s**2 - 2 * s
        v = dh00 * x0 + dh10 * v0 + dh01 * x1 + dh11 * v1
        return x, v


def _rk4_samples(system, h, steps, stride):
    """(x, v) of every node at steps 0, stride, 2 stride, ... of RK4 at h."""
    stepper = get_integrator("rk4")
    x0 = system.net.positions[system.free].reshape(-1)
    v0 = system.net.velocities[system.free].reshape(-1)
    state, t = stepper.start(system, 0.0, x0, v0, h), 0.0
    xs, vs = [], []
    for k in range(0, steps + 1, stride):
        if k:
            t, state = stepper.advance(system, t, state, h, stride)
        x, v = stepper.output(system, t, state, h)
        xs.append(system.full_positions(x))
        vs.append(system.full_velocities(v))
    return np.array(xs), np.array(vs)


def converged_run(net, gravity, drag, t_end, h, store_every) -> ConvergedRun:
    """RK4 at h and at 2h over [0, t_end], stored every `store_every` (even) steps of h."""
    system = NetworkSystem(net, gravity, drag)
    steps = int(round(t_end / h))
    if store_every % 2 or steps % store_every or not np.isclose(steps * h, t_end, rtol=1e-9):
        raise ValueError(f"reference step h = {h:g} s must divide t_end = {t_end:g} s into "
                         f"a multiple of store_every = {store_every} (even) steps")
    x, v = _rk4_samples(system, h, steps, store_every)
    x_coarse, _ = _rk4_samples(system, 2 * h, steps // 2, store_every // 2)
    richardson = np.mean(np.linalg.norm(x - x_coarse, axis=2), axis=1) / RK4_RICHARDSON
    energy = np.array([kinetic_energy(net, vk) + network_potential(net, xk, gravity,
                                                                   system.bending)
                       for xk, vk in zip(x, v)])
    return ConvergedRun(t=np.arange(len(x)) * store_every * h, x=x, v=v, h=h,
                        richardson=richardson, energy=energy,
                        accel=_accelerations(system, x, v))


def _accelerations(system, x, v) -> np.ndarray:
    """(s, n, 3) accelerations of every node (zero on pinned ones) at the stored states."""
    free = system.free
    a = system.accel(0.0, x[:, free].reshape(len(x), -1), v[:, free].reshape(len(x), -1))
    return system.full_velocities(a)
