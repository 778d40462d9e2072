"""The plastic_set case's steppers on its reduced system (`march`, shared by its variants) and
the green variant's tetrahedron reduced to its diagonal stretches (`GreenTet`); the argument
is in cases/fem/plastic_set.py's docstring."""
from __future__ import annotations

import numpy as np

DIRECTION = np.diag([2.0, -1.0, -1.0]) / np.sqrt(6.0)


def march(name, h, e, v, accel, implicit, linearised, commit, steps) -> np.ndarray:
    """(steps + 1, ...) positions e_n of the in-house stepper `name` on e'' = accel(e), the
    plastic return committed after each step; implicit(e, v) the backward Euler root,
    linearised(e, v, a) the Baraff-Witkin velocity. A loop over the run's steps (one element:
    the case's reference, not a hot path)."""
    out, a = [e], accel(e)
    for _ in range(int(steps)):
        if name == "explicit_euler":
            e, v = e + h * v, v + h * a
        elif name == "symplectic_euler":
            v = v + h * a
            e = e + h * v
        elif name == "velocity_verlet":
            half = v + h / 2 * a
            e = e + h * half
            v = half + h / 2 * accel(e)
        elif name == "rk4":
            k1x, k1v = v, a
            k2x, k2v = v + h / 2 * k1v, accel(e + h / 2 * k1x)
            k3x, k3v = v + h / 2 * k2v, accel(e + h / 2 * k2x)
            k4x, k4v = v + h * k3v, accel(e + h * k3x)
            e, v = (e + h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x),
                    v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v))
        elif name == "implicit_euler":
            e1 = implicit(e, v)
            e, v = e1, (e1 - e) / h
        elif name == "baraff_witkin":
            v = linearised(e, v, a)
            e = e + h * v
        else:
            raise ValueError(f"plastic_set has no discrete solution for {name!r}")
        commit(e)
        a = accel(e)
        out.append(e)
    return np.array(out)


class GreenTet:
    """The green variant's tetrahedron as its diagonal stretches l = diag F (3,): StVK with
    refsim's von Mises return on the Green strain (module docstring), l'' = -k l S."""

    def __init__(self, c, lam):
        self.k, self.mu, self.lam, self.e_y = c["k"], c["mu"], lam, c["e_y"]
        self.n, self.omega = np.diag(DIRECTION), c["omega"]
        self.v0 = c["v0"] * self.n
        self._solve()

    def ret(self, l, ep):
        """(elastic strain, plastic strain) after the radial return from ep at l."""
        trial = 0.5 * (l * l - 1.0) - ep
        dev = trial - np.sum(trial) / 3.0
        over = np.linalg.norm(dev) - self.e_y
        if over <= 0:
            return trial, ep
        step = over / np.linalg.norm(dev) * dev
        return trial - step, ep + step

    def accel(self, l, ep):
        e = self.ret(l, ep)[0]
        return -self.k * l * (self.lam * np.sum(e) + 2 * self.mu * e)

    def tangent(self, l):
        """k dP/dl of the elastic StVK law (the in-house Baraff-Witkin and Newton's)."""
        e = 0.5 * (l * l - 1.0)
        s = self.lam * np.sum(e) + 2 * self.mu * e
        return self.k * (np.diag(s + 2 * self.mu * l * l) + self.lam * np.outer(l, l))

    def _solve(self):
        """The converged reference: DOP853 (rtol 1e-13) to yield, through the flow to the
        turning point (n . l l' = 0), then elastic with the plastic strain kept."""
        from scipy.integrate import solve_ivp

        def rhs(ep):
            return lambda t, y: np.concatenate([y[3:], self.accel(y[:3], ep)])

        def yielded(t, y):
            e = 0.5 * (y[:3] ** 2 - 1.0)
            return np.linalg.norm(e - np.sum(e) / 3.0) - self.e_y

        def turned(t, y):
            return self.n @ (y[:3] * y[3:])

        yielded.terminal, turned.terminal, turned.direction = True, True, -1
        tight, zero = {"method": "DOP853", "rtol": 1e-13, "atol": 1e-15,
                       "dense_output": True}, np.zeros(3)
        span = 20.0 / self.omega
        a = solve_ivp(rhs(zero), (0.0, span), np.concatenate([np.ones(3), self.v0]),
                      events=yielded, **tight)
        b = solve_ivp(rhs(zero), (a.t[-1], span), a.y[:, -1], events=turned, **tight)
        self.t_max, self.l_max = b.t[-1], b.y[:3, -1]
        self.e_p = self.ret(self.l_max, zero)[1]
        self.t_end = self.t_max + np.pi / (2 * self.omega)
        c = solve_ivp(rhs(self.e_p), (self.t_max, self.t_end), b.y[:, -1], **tight)
        self.pieces, self.breaks = (a.sol, b.sol, c.sol), np.array([a.t[-1], self.t_max])

    def stretches(self, t) -> np.ndarray:
        """(len(t), 3) diag F of the reference at times t."""
        t = np.atleast_1d(np.asarray(t, float))
        which = np.searchsorted(self.breaks, t)
        out = np.empty((len(t), 3))
        for i, sol in enumerate(self.pieces):
            if np.any(which == i):
                out[which == i] = sol(t[which == i])[:3].T
        return out

    def discrete(self, name, h, steps) -> np.ndarray:
        """(steps + 1, 3) diag F of the in-house stepper `name` (march)."""
        state = {"ep": np.zeros(3)}

        def accel(l):
            return self.accel(l, state["ep"])

        def implicit(l, v):  # Newton with the elastic tangent, as the in-house engine
            l1 = l + h * v
            for _ in range(100):
                step = np.linalg.solve(np.eye(3) + h * h * self.tangent(l1),
                                       l1 - l - h * v - h * h * accel(l1))
                l1 = l1 - step
                if np.max(np.abs(step)) <= 1e-15 * np.max(np.abs(l1)):
                    return l1
            raise RuntimeError("plastic_set green: backward Euler root not found")

        def linearised(l, v, a):
            j = self.tangent(l)
            return v + np.linalg.solve(np.eye(3) + h * h * j, h * (a - h * j @ v))

        def commit(l):
            state["ep"] = self.ret(l, state["ep"])[1]

        return march(name, h, np.ones(3), self.v0.copy(), accel, implicit, linearised,
                     commit, steps)
