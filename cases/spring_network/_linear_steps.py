"""Closed-form step matrices of the four network steppers on a LINEAR system
x'' = A x + B v (A, B square, n x n; scalars for one mode), written from each method's
definition, not from its code, so that a case can predict a run exactly:

    (x, v)_{k+1} = S(h) (x, v)_k,   S of size 2n x 2n.

- symplectic_euler (kick then drift): v1 = v + h (A x + B v); x1 = x + h v1.
- velocity_verlet: vh = v + h/2 a(x, v); x1 = x + h vh; v1 = vh + h/2 a(x1, vh), and, when B
  is not zero, the closing half kick repeated once with that v1 (refsim's second-order form for
  velocity-dependent forces, refsim.integrators.symplectic.VelocityVerlet); with B = 0 it is
  the plain velocity Verlet (the starting acceleration is a(x0, v0), so S maps (x, v) alone).
- rk4: the classical tableau on z' = J z, J = [[0, I], [A, B]]: S = sum_{k<=4} (h J)^k / k!.
- baraff_witkin: one Newton step of backward Euler, exact on linear forces:
  S = (I - h J)^-1 (Baraff & Witkin 1998, sec. 4.1).
"""
from __future__ import annotations

import math

import numpy as np

STEPPERS = ("symplectic_euler", "velocity_verlet", "rk4", "baraff_witkin")


def _blocks(a, b) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    a = np.atleast_2d(np.asarray(a, float))
    b = np.zeros_like(a) if b is None else np.atleast_2d(np.asarray(b, float))
    return a, b, np.eye(len(a))


def first_order_matrix(a, b=None) -> np.ndarray:
    """J = [[0, I], [A, B]]: z' = J z for z = (x, v)."""
    a, b, eye = _blocks(a, b)
    return np.block([[np.zeros_like(a), eye], [a, b]])


def step_matrix(integrator: str, a, b, h: float) -> np.ndarray:
    """S(h) of the named stepper on x'' = A x + B v (module doc); ValueError for another."""
    a, b, eye = _blocks(a, b)
    zero = np.zeros_like(a)
    if integrator == "symplectic_euler":
        kick = np.block([[eye, zero], [h * a, eye + h * b]])
        drift = np.block([[eye, h * eye], [zero, eye]])
        return drift @ kick
    if integrator == "velocity_verlet":
        return _velocity_verlet(a, b, eye, h)
    jac = first_order_matrix(a, b)
    big = np.eye(len(jac))
    if integrator == "rk4":
        hj, out, term = h * jac, big.copy(), big.copy()
        for k in range(1, 5):
            term = term @ hj / k
            out = out + term
        return out
    if integrator == "baraff_witkin":
        return np.linalg.inv(big - h * jac)
    raise ValueError(f"integrator must be one of {list(STEPPERS)} for a closed-form step, "
                     f"got {integrator!r}")


def _velocity_verlet(a, b, eye, h) -> np.ndarray:
    """Rows act on (x, v): half kick, drift, half kick (repeated once when B != 0)."""
    accel = np.hstack([a, b])                          # a(x, v) as a row block on (x, v)
    vh = np.hstack([np.zeros_like(a), eye]) + 0.5 * h * accel
    x1 = np.hstack([eye, np.zeros_like(a)]) + h * vh
    v1 = vh + 0.5 * h * (a @ x1 + b @ vh)
    if np.any(b):
        v1 = vh + 0.5 * h * (a @ x1 + b @ v1)
    return np.vstack([x1, v1])


def mode_amplitude(integrator: str, omega: float, h: float, steps) -> np.ndarray:
    """[S^k]_00 for each k in steps: the displacement, from rest at 1, of an undamped mode
    x'' = -omega^2 x after k steps (by S's eigenvalues, so every k costs the same)."""
    s = step_matrix(integrator, -omega ** 2, None, h)
    values, vectors = np.linalg.eig(s)
    coeffs = np.linalg.solve(vectors, np.array([1.0, 0.0]))
    powers = np.power(values[None, :], np.asarray(steps, float)[:, None])
    return np.real(powers @ (vectors[0] * coeffs))


def backward_euler_factor(y: float) -> tuple[float, float]:
    """(amplitude factor, phase advance) per step of backward Euler (= Baraff-Witkin) on an
    undamped mode, y = omega h: the eigenvalues of (I - h J)^-1 are 1 / (1 -+ i y), modulus
    (1 + y^2)^(-1/2) and argument +-arctan(y)."""
    return 1.0 / math.sqrt(1.0 + y * y), math.atan(y)
