"""Steppers for FIRST-ORDER systems p' = u(t, p) (slide 003: advection of massless particles,
gradient descent p_{i+1} = p_i - h grad E(p_i), Witkin-Heckbert sampling).

The steppers of `refsim.integrators` advance second-order systems (x, v); casting p' = u as
x'' = ... would make their stages other methods. These run the SAME Butcher tableaux
(`tableaux.EULER`, `MIDPOINT`, `HEUN`, `rk2_tableau(2/3)` (Ralston), `RK4`) on p itself:

    k_i = u(t + c_i h, p + h sum_j a_ij k_j),        p_1 = p + h sum_i b_i k_i

and implicit Euler p_1 = p + h u(t + h, p_1) for a field that is affine in p (one linear
solve per step: (I - h J) (p_1 - p) = h u(t + h, p), J = du/dp; exact for an affine u).

The first-order system a stepper takes (physics lives in `refsim.models`):

    field.velocity(t, p) -> u    p and u of shape (..., n, 3): any leading batch axes
    field.linear                 True when u is affine in p (implicit Euler needs it)
    field.jacobian(t, p) -> J    (3, 3): du_i/dp_i, the same for every particle (affine fields)
    field.project(p) -> p'       optional: applied after every step (a projection method,
                                 Hairer, Lubich & Wanner, Geometric Numerical Integration,
                                 2006, sec. IV.4: the stages run unprojected)

On p' = z p (the linear test equation) one step multiplies p by the stability function R(z):
`stability_function(name)` gives it from the tableau (R(z) = 1 + sum_m z^m b^T A^(m-1) 1 for an
explicit tableau, 1 / (1 - z) for implicit Euler), and `step_matrix` gives R(h M) for p' = M p:
the exact discrete solution c + R(h M)^k (p_0 - c) of every affine field u = M (p - c).

These are NOT in `refsim.integrators.INTEGRATORS` (which second-order engines offer);
`get_first_order(name)` builds one: 'explicit_euler', 'midpoint', 'heun', 'rk2' (Ralston,
alpha 2/3; 'rk2:alpha' for another), 'rk4', 'implicit_euler'.
"""
from __future__ import annotations

import numpy as np

from .spec import IntegratorSpec
from .tableaux import EULER, HEUN, MIDPOINT, RK4, Tableau, rk2_tableau


class FirstOrderStepper:
    """Contract: `step(field, t, p, h)` returns p one step of h later; `advance` loops it."""

    name = "first_order"
    order = 0
    family = ""
    explicit = True
    symplectic = False

    def step(self, field, t, p, h):
        raise NotImplementedError

    def advance(self, field, t, p, h, n):
        """n steps of h from time t (then `field.project` after each, if it has one);
        returns (t_new, p)."""
        project = getattr(field, "project", None)
        for k in range(n):
            p = self.step(field, t + k * h, p, h)
            if project is not None:
                p = project(p)
        return t + n * h, p

    def stability(self, z):
        """R(z): one step of p' = z p multiplies p by it (z complex, any shape)."""
        raise NotImplementedError

    def step_matrix(self, matrix, h):
        """R(h M) for p' = M p (M (..., d, d)): p_1 = R(h M) p exactly."""
        raise NotImplementedError

    def describe(self) -> dict:
        return {"name": self.name, "order": self.order, "family": self.family,
                "explicit": self.explicit, "symplectic": self.symplectic,
                "system": "first order p' = u(t, p)"}


def polynomial_coefficients(tableau: Tableau) -> np.ndarray:
    """Coefficients g_0..g_s of an explicit tableau's stability polynomial R(z) = sum g_m z^m:
    g_0 = 1, g_m = b^T A^(m-1) 1 (A strictly lower triangular, so A^s = 0)."""
    a, b, _ = tableau.arrays()
    coeffs, power = [1.0], np.ones(len(b))
    for _ in range(len(b)):
        coeffs.append(float(b @ power))
        power = a @ power
    return np.array(coeffs)


class FirstOrderRK(FirstOrderStepper):
    """An explicit Runge-Kutta tableau run on p' = u(t, p) (see the module docstring)."""

    family = "explicit Runge-Kutta (first-order system)"

    def __init__(self, name: str, tableau: Tableau):
        self.name, self.tableau, self.order = name, tableau, tableau.order
        a, b, c = tableau.arrays()
        # later stages as (c_i, ((j, a_ij), ...)) with the non-zero couplings only
        self._later_stages = tuple(
            (float(c[i]), tuple((j, float(a[i, j])) for j in range(i) if a[i, j] != 0))
            for i in range(1, len(c)))
        self._weights = tuple((i, float(b[i])) for i in range(len(b)) if b[i] != 0)
        self.coefficients = polynomial_coefficients(tableau)

    def step(self, field, t, p, h):
        velocity = field.velocity
        slopes = [velocity(t, p)]
        for ci, couplings in self._later_stages:
            stage = p
            for j, aij in couplings:
                stage = stage + (aij * h) * slopes[j]
            slopes.append(velocity(t + ci * h, stage))
        for i, bi in self._weights:
            p = p + (bi * h) * slopes[i]
        return p

    def stability(self, z):
        z = np.asarray(z, complex)
        return sum(g * z ** m for m, g in enumerate(self.coefficients))

    def step_matrix(self, matrix, h):
        z = h * np.asarray(matrix, float)
        out, power = np.zeros_like(z), np.broadcast_to(np.eye(z.shape[-1]), z.shape)
        for g in self.coefficients:
            out = out + g * power
            power = power @ z
        return out


class FirstOrderImplicitEuler(FirstOrderStepper):
    """p_1 = p + h u(t + h, p_1) for an affine field: (I - h J) dp = h u(t + h, p), one solve
    of the 3 x 3 system per step with every particle a right-hand side."""

    name, order, family, explicit = ("implicit_euler", 1, "implicit (first-order system, one "
                                     "linear solve per step)", False)

    def step(self, field, t, p, h):
        if not getattr(field, "linear", False):
            raise ValueError("implicit_euler (first order) needs a field affine in p "
                             "(field.linear True): one linear solve per step")
        jac = np.asarray(field.jacobian(t + h, p), float)
        rhs = h * field.velocity(t + h, p)  # (..., n, 3)
        matrix = np.eye(3) - h * jac
        dp = np.linalg.solve(matrix, np.swapaxes(rhs, -1, -2))  # 3 x n right-hand sides
        return p + np.swapaxes(dp, -1, -2)

    def stability(self, z):
        return 1.0 / (1.0 - np.asarray(z, complex))

    def step_matrix(self, matrix, h):
        z = h * np.asarray(matrix, float)
        return np.linalg.inv(np.eye(z.shape[-1]) - z)


_FACTORIES = {
    "explicit_euler": lambda: FirstOrderRK("explicit_euler", EULER),
    "midpoint": lambda: FirstOrderRK("midpoint", MIDPOINT),
    "heun": lambda: FirstOrderRK("heun", HEUN),
    "rk2": lambda: FirstOrderRK("rk2", rk2_tableau(2.0 / 3.0)),
    "rk4": lambda: FirstOrderRK("rk4", RK4),
    "implicit_euler": FirstOrderImplicitEuler,
}
FIRST_ORDER = tuple(_FACTORIES)
EXPLICIT_FIRST_ORDER = tuple(n for n in FIRST_ORDER if n != "implicit_euler")


def get_first_order(spec: str) -> FirstOrderStepper:
    """'explicit_euler', 'midpoint', 'heun', 'rk2' (Ralston) or 'rk2:alpha', 'rk4',
    'implicit_euler'."""
    parsed = IntegratorSpec.parse(spec)
    name = parsed.name
    if name not in _FACTORIES:
        raise ValueError(f"first-order integrator must be one of {list(_FACTORIES)}, got "
                         f"{spec!r}")
    if not parsed.arg:
        return _FACTORIES[name]()
    if name != "rk2":
        raise ValueError(f"first-order integrator {name!r} takes no parameter, got {spec!r}")
    alpha = parsed.number("alpha in (0, 1]")
    return FirstOrderRK(f"rk2:{alpha:g}", rk2_tableau(alpha))
