"""Every time stepper of the course slides, each declaring its order and family.

A stepper advances a second-order system x'' = a(t, x, v) given by a *system* object (physics
lives elsewhere, in `refsim.models`):

    system.accel(t, x, v) -> a                   arrays of shape (..., n): any leading batch axes
                                                 (or 0-d scalars for one degree of freedom)
    system.jacobians(t, x, v) -> (da_dx, da_dv)  shape (..., n, n); implicit methods only
    system.linear              True when a is affine in (x, v): one Newton step is exact
    system.velocity_dependent  True when a depends on v (damping, drag, Baumgarte terms)

Contract for an implementer of a new stepper (subclass `Integrator`):
1. declare `name`, `order`, `family`, `explicit`, `symplectic` as class attributes;
2. `start(system, t, x, v, h)` turns (x, v) into the stepper's state tuple (default: (x, v));
3. `step(system, t, state, h)` returns the state one step of h later; it must not observe;
4. `output(system, t, state, h)` returns synchronised (x, v) (default: the first two entries).

Explicit Runge-Kutta methods are Butcher tableaux (data) run by the one `ExplicitRK` stepper.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


class StepFailure(RuntimeError):
    """A step could not be completed (Newton did not converge, adaptive step underflow)."""


# --------------------------------------------------------------------------------------------
# Butcher tableaux (data)
# --------------------------------------------------------------------------------------------
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


# --------------------------------------------------------------------------------------------
# Base class
# --------------------------------------------------------------------------------------------
class Integrator:
    name = "base"
    order = 0
    family = ""
    explicit = True
    symplectic = False
    adaptive = False

    def start(self, system, t, x, v, h):
        return (x, v)

    def step(self, system, t, state, h):
        raise NotImplementedError

    def output(self, system, t, state, h):
        return state[0], state[1]

    def advance(self, system, t, state, h, n):
        """n steps of h from time t; returns (t_new, state). The time loop of every engine."""
        step = self.step
        for k in range(n):
            state = step(system, t + k * h, state, h)
        return t + n * h, state

    def describe(self) -> dict:
        return {"name": self.name, "order": self.order, "family": self.family,
                "explicit": self.explicit, "symplectic": self.symplectic}


class ExplicitRK(Integrator):
    """One stepper for every explicit Runge-Kutta tableau, on y = (x, v), y' = (v, a)."""

    family = "explicit Runge-Kutta"

    def __init__(self, name: str, tableau: Tableau):
        self.name, self.tableau, self.order = name, tableau, tableau.order
        a, b, c = tableau.arrays()
        # keep only the non-zero couplings, as plain floats (a numpy scalar would turn a
        # plain-float state into numpy scalars, three times slower per operation)
        self._rows = [[(j, float(a[i, j])) for j in range(i) if a[i, j] != 0]
                      for i in range(len(c))]
        self._b = [(i, float(b[i])) for i in range(len(b)) if b[i] != 0]
        self._c = [float(ci) for ci in c]
        self._h = None

    def _scaled(self, h):
        """Tableau coefficients times h, cached for the last h (steps repeat the same h)."""
        if h != self._h:
            self._h = h
            self._hrows = [(ci * h, [(j, aij * h) for j, aij in row])
                           for ci, row in zip(self._c, self._rows)]
            self._hb = [(i, bi * h) for i, bi in self._b]
        return self._hrows, self._hb

    def stages(self, system, t, x, v, h):
        rows, _ = self._scaled(h)
        accel = system.accel
        kx, kv = [v], [accel(t, x, v)]  # explicit: the first stage has no couplings
        for ch, row in rows[1:]:
            xi, vi = x, v
            for j, c in row:
                xi = xi + c * kx[j]
                vi = vi + c * kv[j]
            kx.append(vi)
            kv.append(accel(t + ch, xi, vi))
        return kx, kv

    def step(self, system, t, state, h):
        x, v = state
        kx, kv = self.stages(system, t, x, v, h)
        for i, c in self._hb:
            x = x + c * kx[i]
            v = v + c * kv[i]
        return (x, v)


class AdaptiveDormandPrince(ExplicitRK):
    """Dormand-Prince 5(4) with error control; each call to `step` lands exactly on t + h.

    `h` is the output interval; inside it, steps are chosen so that the embedded 4th-order error
    estimate satisfies ||err / (atol + rtol max(|y0|, |y1|))||_rms <= 1 (Hairer, Norsett & Wanner,
    Solving ODEs I, II.4), with the standard safety factor 0.9 and growth limits [0.2, 5].
    """

    family = "adaptive explicit Runge-Kutta"
    adaptive = True

    def __init__(self, rtol=1e-9, atol=1e-12):
        super().__init__("dopri5_adaptive", DOPRI5)
        for label, tol in (("rtol", rtol), ("atol", atol)):
            if not np.isfinite(tol) or tol <= 0:
                raise ValueError(f"dopri5_adaptive {label} must be > 0, got {tol}")
        self.rtol, self.atol = float(rtol), float(atol)
        self._e = [(i, bi - bl) for i, (bi, bl) in enumerate(zip(DOPRI5.b, DOPRI5.b_low))
                   if bi != bl]
        self.name = f"dopri5_adaptive:{self.rtol:g}"

    def start(self, system, t, x, v, h):
        return (x, v, h)

    def output(self, system, t, state, h):
        return state[0], state[1]

    def _trial(self, system, t, x, v, h):
        kx, kv = self.stages(system, t, x, v, h)
        x1, v1, ex, ev = x, v, 0.0, 0.0
        for i, bi in self._b:
            x1 = x1 + (h * bi) * kx[i]
            v1 = v1 + (h * bi) * kv[i]
        for i, ei in self._e:
            ex = ex + (h * ei) * kx[i]
            ev = ev + (h * ei) * kv[i]
        sx = self.atol + self.rtol * np.maximum(np.abs(x), np.abs(x1))
        sv = self.atol + self.rtol * np.maximum(np.abs(v), np.abs(v1))
        err = np.sqrt(0.5 * (np.mean((ex / sx) ** 2) + np.mean((ev / sv) ** 2)))
        return x1, v1, err

    def step(self, system, t, state, h):
        x, v, hi = state
        t_end, tc = t + h, t
        while tc < t_end:
            hs = min(hi, t_end - tc)
            if hs <= 1e-14 * max(1.0, abs(tc)):
                raise StepFailure("dopri5_adaptive: step size underflow")
            x1, v1, err = self._trial(system, tc, x, v, hs)
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


# --------------------------------------------------------------------------------------------
# Symplectic and Verlet steppers
# --------------------------------------------------------------------------------------------
class SymplecticEulerKD(Integrator):
    """Kick then drift: v1 = v + h a(x, v); x1 = x + h v1 (semi-implicit Euler of most engines)."""

    name, order, family, symplectic = "symplectic_euler", 1, "symplectic Euler", True

    def step(self, system, t, state, h):
        x, v = state
        v = v + h * system.accel(t, x, v)
        return (x + h * v, v)


class SymplecticEulerDK(Integrator):
    """Drift then kick: x1 = x + h v; v1 = v + h a(x1, v)."""

    name, order, family, symplectic = "symplectic_euler_dk", 1, "symplectic Euler", True

    def step(self, system, t, state, h):
        x, v = state
        x = x + h * v
        return (x, v + h * system.accel(t + h, x, v))


class VelocityVerlet(Integrator):
    """Half kick, drift, half kick; the acceleration is carried to the next step (1 eval/step).

    With velocity-dependent forces the closing half kick is corrected once with the new
    velocity, which keeps second order (the plain explicit form drops to first).
    """

    name, order, family, symplectic = "velocity_verlet", 2, "Verlet", True

    def start(self, system, t, x, v, h):
        return (x, v, system.accel(t, x, v))

    def step(self, system, t, state, h):
        x, v, a = state
        vh = v + (0.5 * h) * a
        x = x + h * vh
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
    v_n = d_n / h + h/2 a(x_n), which equals velocity Verlet's.
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

    def step(self, system, t, state, h):
        x, d = state
        v = self._velocity(system, t, x, d, h) if system.velocity_dependent else d / h
        d = d + (h * h) * system.accel(t, x, v)
        return (x + d, d)

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

    def step(self, system, t, state, h):
        x, vm = state
        v = self._sync(system, t, x, vm, h) if system.velocity_dependent else vm
        vm = vm + h * system.accel(t, x, v)
        return (x + h * vm, vm)

    def output(self, system, t, state, h):
        x, vm = state
        return x, self._sync(system, t, x, vm, h)


# --------------------------------------------------------------------------------------------
# Implicit steppers
# --------------------------------------------------------------------------------------------
def _solve(matrix, rhs):
    if np.ndim(rhs) == 0:  # scalar state (one degree of freedom, no batch)
        return rhs / matrix
    return np.linalg.solve(matrix, rhs[..., None])[..., 0]


def _matvec(matrix, vector):
    return matrix * vector if np.ndim(vector) == 0 else np.einsum("...ij,...j->...i", matrix,
                                                                  vector)


def _implicit_matrix(system, t, x, v, h):
    ax, av = system.jacobians(t, x, v)
    eye = 1.0 if np.ndim(x) == 0 else np.eye(x.shape[-1])
    return eye - h * av - (h * h) * ax, ax


class ImplicitEuler(Integrator):
    """Backward Euler: v1 = v + h a(x + h v1, v1), x1 = x + h v1.

    Solved for v1 by simplified Newton (Hairer & Wanner, Solving ODEs II, IV.8): the matrix
    J = I - h da/dv - h^2 da/dx is formed once per step at the explicit-Euler predictor and
    reused; the iteration converges linearly at a rate of order h^2 |dJ|, and in one step for
    a linear system (the direct solve). Converged when the update is below `tol` relative to
    |v1|; `StepFailure` after `max_iter`.
    """

    name, order, family, explicit = "implicit_euler", 1, "implicit", False

    def __init__(self, tol=1e-13, max_iter=50):
        self.tol, self.max_iter = tol, max_iter

    def step(self, system, t, state, h):
        x, v = state
        t1 = t + h
        v1 = v + h * system.accel(t, x, v)
        jac, _ = _implicit_matrix(system, t1, x + h * v1, v1, h)
        for _ in range(1 if system.linear else self.max_iter):
            residual = v1 - v - h * system.accel(t1, x + h * v1, v1)
            dv = _solve(jac, residual)
            v1 = v1 - dv
            if system.linear or np.max(np.abs(dv)) <= self.tol * (1.0 + np.max(np.abs(v1))):
                break
        else:
            raise StepFailure(f"implicit_euler: Newton did not converge in {self.max_iter} "
                              "iterations")
        return (x + h * v1, v1)


class BaraffWitkin(Integrator):
    """Baraff & Witkin (1998) linearised backward Euler for spring systems:

    (M - h df/dv - h^2 df/dx) dv = h (f0 + h df/dx v0), here divided through by M.
    One Newton step of backward Euler from v0; identical to it for linear forces.
    """

    name, order, family, explicit = "baraff_witkin", 1, "implicit (linearised)", False

    def step(self, system, t, state, h):
        x, v = state
        jac, ax = _implicit_matrix(system, t, x, v, h)
        rhs = h * (system.accel(t, x, v) + h * _matvec(ax, v))
        v1 = v + _solve(jac, rhs)
        return (x + h * v1, v1)


# --------------------------------------------------------------------------------------------
# Registry
# --------------------------------------------------------------------------------------------
_FACTORIES = {
    "explicit_euler": lambda: ExplicitRK("explicit_euler", EULER),
    "implicit_euler": ImplicitEuler,
    "symplectic_euler": SymplecticEulerKD,
    "symplectic_euler_dk": SymplecticEulerDK,
    "midpoint": lambda: ExplicitRK("midpoint", MIDPOINT),
    "heun": lambda: ExplicitRK("heun", HEUN),
    "rk2": lambda: ExplicitRK("rk2", rk2_tableau(2.0 / 3.0)),
    "rk4": lambda: ExplicitRK("rk4", RK4),
    "dopri5": lambda: ExplicitRK("dopri5", DOPRI5),
    "dopri5_adaptive": AdaptiveDormandPrince,
    "stormer_verlet": StormerVerlet,
    "velocity_verlet": VelocityVerlet,
    "leapfrog": Leapfrog,
    "baraff_witkin": BaraffWitkin,
}
INTEGRATORS = tuple(_FACTORIES)
PARAMETRISED = {"rk2": "alpha in (0, 1], default 2/3 (Ralston)",
                "dopri5_adaptive": "rtol > 0, default 1e-9 (atol = rtol * 1e-3)"}


def get_integrator(spec: str) -> Integrator:
    """'rk4', 'rk2:0.5' (alpha), 'dopri5_adaptive:1e-8' (rtol)."""
    name, _, arg = str(spec).partition(":")
    if name not in _FACTORIES:
        raise ValueError(f"integrator must be one of {list(_FACTORIES)}, got {spec!r}")
    if not arg:
        return _FACTORIES[name]()
    if name not in PARAMETRISED:
        raise ValueError(f"integrator {name!r} takes no parameter, got {spec!r}")
    try:
        value = float(arg)
    except ValueError:
        raise ValueError(f"integrator {name} parameter: {PARAMETRISED[name]}; got {arg!r}") from None
    if name == "rk2":
        return ExplicitRK(f"rk2:{value:g}", rk2_tableau(value))
    return AdaptiveDormandPrince(rtol=value, atol=value * 1e-3)
