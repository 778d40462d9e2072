"""Affine velocity fields u = M (p - c) for first-order particle dynamics (slide 003): advection
in a rigid vortex and gradient descent on a quadratic (`refsim.scene.velocity_field`).

`AffineField` is the first-order system `refsim.integrators.first_order` steps: velocity(t, p)
over (..., n, 3) (any leading batch axes), `linear`, `jacobian`. Exact discrete oracles:

- one step of any stepper of stability function R on an affine field is p_1 - c = R(h M)
  (p - c); after k steps p_k = c + R(h M)^k (p_0 - c) (`discrete_positions`, evaluated in
  M's eigenbasis: R(h lambda)^k per mode);
- rigid vortex, y = |Omega| h: in the plane normal to Omega the step multiplies the complex
  coordinate by R(i y): the radius grows by |R(i y)| a step and turns by arg R(i y)
  (`vortex_radius_factor`, `vortex_step_angle`); along Omega nothing moves. Closed forms
  (docs/models.md#fields-vortex-radius-per-step): forward Euler sqrt(1 + y^2); any two-stage
  second-order method (midpoint, Heun, Ralston) sqrt(1 + y^4/4); RK4 sqrt(1 - y^6/72 +
  y^8/576); implicit Euler 1/sqrt(1 + y^2);
- quadratic descent: per axis p_k - c = R(-h lambda)^k (p_0 - c): forward Euler's (1 - h
  lambda)^k, stable iff |1 - h lambda| < 1, i.e. h < 2/lambda; implicit Euler 1/(1 + h lambda).
The continuum: p(t) = c + expm(t M) (p_0 - c) (`exact_positions`, exp(t lambda) per mode).
"""
from __future__ import annotations

import numpy as np


class AffineField:
    """u(t, p) = M (p - c) on (..., n, 3) arrays (autonomous: t unused)."""

    linear = True

    def __init__(self, matrix, centre):
        self.matrix = np.array(matrix, float).reshape(3, 3)
        self.centre = np.array(centre, float).reshape(3)
        self._matrix_t = self.matrix.T.copy()

    def velocity(self, t, p):
        return (p - self.centre) @ self._matrix_t

    def jacobian(self, t, p):
        return self.matrix


def modes(matrix):
    """(eigenvalues (3,), V, V^-1) of M: both fields' M are normal (skew or diagonal), so V is
    unitary to round-off and a function of M is V diag(f(lambda)) V^-1 with O(eps) error."""
    values, vectors = np.linalg.eig(np.asarray(matrix, float))
    return values, vectors, np.linalg.inv(vectors)


def propagate(matrix, centre, p0, factors) -> np.ndarray:
    """(T, n, 3): c + V diag(f_t) V^-1 (p_0 - c) for the modal factors f (T, 3) of M's
    eigenvalues (exp(t lambda) for the flow, R(h lambda)^k for a stepper)."""
    _, vectors, inverse = modes(matrix)
    coords = (np.asarray(p0, float) - centre) @ inverse.T  # (n, 3) modal coordinates
    return centre + ((np.asarray(factors)[:, None, :] * coords[None]) @ vectors.T).real


def flow_factors(matrix, t) -> np.ndarray:
    """(T, 3): exp(t lambda) per eigenvalue of M."""
    return np.exp(np.multiply.outer(np.asarray(t, float), modes(matrix)[0]))


def discrete_factors(stepper, matrix, h, steps) -> np.ndarray:
    """(T, 3): R(h lambda)^k per eigenvalue, k in `steps`: the stepper's exact discrete
    solution (one step is R(h M) = V diag(R(h lambda)) V^-1)."""
    factor = stepper.stability(h * modes(matrix)[0])
    return factor[None, :] ** np.asarray(steps, float)[:, None]


def exact_positions(matrix, centre, p0, t) -> np.ndarray:
    """(T, n, 3): the flow c + expm(t M) (p_0 - c) at times t (T,)."""
    return propagate(matrix, centre, p0, flow_factors(matrix, t))


def discrete_positions(stepper, matrix, centre, p0, h, steps) -> np.ndarray:
    """(T, n, 3): c + R(h M)^k (p_0 - c) after k in `steps` steps of h."""
    return propagate(matrix, centre, p0, discrete_factors(stepper, matrix, h, steps))


def vortex_radius_factor(stepper, y):
    """|R(i y)|: the per-step growth of the distance from the vortex axis."""
    return np.abs(stepper.stability(1j * np.asarray(y, float)))


def vortex_step_angle(stepper, y):
    """arg R(i y): the angle the step turns about the vortex axis (y for the flow)."""
    return np.angle(stepper.stability(1j * np.asarray(y, float)))


def axial_radius(p, centre, axis) -> np.ndarray:
    """(...,): the distance of points p (..., 3) from the line through c along `axis`."""
    unit = np.asarray(axis, float) / np.linalg.norm(axis)
    rel = np.asarray(p, float) - centre
    return np.linalg.norm(rel - (rel @ unit)[..., None] * unit, axis=-1)
