"""The four orientation formulations of the rigid-body model, each a configuration update.

Every formulation stores one body's orientation as a row of `size` floats (any leading batch
and body axes) and moves it by a world-frame rotation vector phi (= h w for one Euler step),
the world angular velocity acting on the LEFT (R' = [w]_x R, q' = 1/2 (0, w) (x) q):

    quat_exp         q (4):        q' = exp(phi / 2) (x) q                  (the exact Lie step)
    quat_normalised  q, log c (5): q~ = q + 1/2 (0, phi) (x) q,  q' = q~ / |q~|,
                                   log c' = log c + log |q~|^2           (Cayley map on SO(3))
    matrix_printed   R (9):        R' = R + [phi]_x R                   (the slides, no repair)
    matrix_polar     R (9):        R' = polar(R + [phi]_x R)           (SVD: U V^T)

Orientation defect (`defect`), what each formulation leaves or hides
(docs/models.md#rigid-orientation-defect-per-step):
quat_exp |q|^2 - 1; quat_normalised the cumulative squared norm removed by normalising,
prod_k |q~_k|^2 - 1 = expm1(log c) (renormalisation hides it; it is carried in the fifth
column so that it is a function of the state, correct under any stepper: stage updates start
from the step's configuration and only the accepted update accumulates); matrices
max |R^T R - I| (and `det_defect`: det R - 1).

`dinv(phi, a)`: the inverse differential of the formulation's coordinate map
phi -> shift(o, phi) at phi, applied to a tangent vector a (Runge-Kutta-Munthe-Kaas stage
correction; Iserles, Munthe-Kaas, Norsett & Zanna, Acta Numerica 2000, sections 3-4):
- exp:    dexp^-1_phi a = a - 1/2 phi x a + (1 - (t/2) cot(t/2)) / t^2 phi x (phi x a), t = |phi|
- Cayley: dcay^-1_phi a = a - 1/2 phi x a + 1/4 phi (phi . a)        (q~ normalised = cay(phi))
- polar:  polar(I + [phi]_x) = exp(g(phi)), g = atan(t)/t phi, so the map's inverse
          differential is Dg^-1 dexp^-1_g(phi): Dg^-1 b = b t/atan(t) + (1 + t^2 - t/atan(t))
          phi (phi . b) / t^2
- matrix_printed has none: I + [phi]_x is not on the group (first-order retraction only).
"""
from __future__ import annotations

import numpy as np

from .rigid_body import (
    cross,
    dot,
    matrix_to_quaternion,
    quaternion_multiply,
    quaternion_to_matrix,
    skew,
)

SMALL_ANGLE = 1e-6  # below this |phi| the series limits replace the closed forms: every
#                     closed-form coefficient below has an absolute round-off error of about
#                     eps / |phi|^2 multiplying a term of size |phi|^2 |a|, so eps |a| overall;
#                     the guard only avoids 0 / 0 at phi = 0 (the limits are then exact to eps)


_TINY = np.finfo(float).tiny  # the smallest normal float


def _angle(phi):
    """|phi| as (..., 1)."""
    return np.sqrt(dot(phi, phi))


def quaternion_exp_half(phi):
    """exp(phi / 2) as a unit quaternion (cos |phi|/2, sin(|phi|/2) phi / |phi|). At phi = 0
    the ratio's guard (|phi| floored at the smallest normal) multiplies phi = 0: the vector
    part is 0, as the limit; below the floor sin(|phi|/2) / |phi| is 1/2 to round-off."""
    angle = _angle(phi)
    half = 0.5 * angle
    ratio = np.sin(half) / np.maximum(angle, _TINY)
    return np.concatenate([np.cos(half), ratio * phi], axis=-1)


def dexp_inverse(phi, a):
    """dexp^-1_phi a on so(3) as 3-vectors (module docstring), with
    phi x (phi x a) = phi (phi . a) - a |phi|^2."""
    angle2 = dot(phi, phi)
    angle = np.sqrt(angle2)
    half = 0.5 * np.maximum(angle, SMALL_ANGLE)
    coef = np.where(angle > SMALL_ANGLE, (1.0 - half / np.tan(half)) / (4.0 * half * half),
                    1.0 / 12.0)
    return a - 0.5 * cross(phi, a) + coef * (phi * dot(phi, a) - angle2 * a)


def dcay_inverse(phi, a):
    """dcay^-1_phi a on so(3) as 3-vectors (module docstring)."""
    return a - 0.5 * cross(phi, a) + 0.25 * phi * dot(phi, a)


def dpolar_inverse(phi, a):
    """The inverse differential of phi -> polar(I + [phi]_x) (module docstring)."""
    angle = _angle(phi)
    safe = np.maximum(angle, SMALL_ANGLE)
    ratio = np.where(angle > SMALL_ANGLE, safe / np.arctan(safe), 1.0)  # t / atan t
    axial = np.where(angle > SMALL_ANGLE, (1.0 + safe * safe - ratio) / (safe * safe), 2 / 3)
    g = phi / ratio
    b = dexp_inverse(g, a)
    return ratio * b + axial * phi * dot(phi, b)


def polar_factor(matrix):
    """The orthogonal polar factor U V^T of each (..., 3, 3) matrix (SVD)."""
    u, _, vt = np.linalg.svd(matrix)
    return u @ vt


class Formulation:
    """One orientation formulation (see the module docstring). Rows (..., size)."""

    name = ""
    description = ""
    size = 4
    orthogonal = True  # the stored orientation is a rotation (to round-off)
    # the highest order any stepper reaches through this update (None: the stepper's own)
    order_limit = None
    dinv = None  # the coordinate map's inverse differential, or None

    def from_quaternion(self, q):
        raise NotImplementedError

    def matrix(self, o):
        """(..., 3, 3) rotation (body to world) the orientation stands for."""
        raise NotImplementedError

    def quaternion(self, o):
        """(..., 4) unit quaternion (w, x, y, z) of the orientation."""
        raise NotImplementedError

    def shift(self, o, phi):
        raise NotImplementedError

    def defect(self, o):
        raise NotImplementedError

    def det_defect(self, o):
        """det R - 1 of the stored (or represented) rotation."""
        return np.linalg.det(self.matrix(o)) - 1.0


class QuaternionExp(Formulation):
    name, size = "quat_exp", 4
    description = "unit quaternion moved by the exponential map q' = exp(h w / 2) (x) q"
    dinv = staticmethod(dexp_inverse)

    def from_quaternion(self, q):
        return np.array(q, float)

    def matrix(self, o):
        return quaternion_to_matrix(o)

    def quaternion(self, o):
        return o / np.linalg.norm(o, axis=-1, keepdims=True)

    def shift(self, o, phi):
        return quaternion_multiply(quaternion_exp_half(phi), o)

    def defect(self, o):
        return np.sum(o * o, axis=-1) - 1.0


class QuaternionNormalised(Formulation):
    name, size = "quat_normalised", 5
    description = ("quaternion Euler update q + h/2 (0, w) (x) q, then normalised; the squared "
                   "norm removed is accumulated and reported")
    dinv = staticmethod(dcay_inverse)

    def from_quaternion(self, q):
        q = np.asarray(q, float)
        return np.concatenate([q, np.zeros(q.shape[:-1] + (1,))], axis=-1)

    def matrix(self, o):
        return quaternion_to_matrix(o[..., :4])

    def quaternion(self, o):
        return o[..., :4] / np.linalg.norm(o[..., :4], axis=-1, keepdims=True)

    def shift(self, o, phi):
        q = o[..., :4]
        pure = np.concatenate([np.zeros(phi.shape[:-1] + (1,)), 0.5 * phi], axis=-1)
        moved = q + quaternion_multiply(pure, q)
        norm2 = np.sum(moved * moved, axis=-1, keepdims=True)
        return np.concatenate([moved / np.sqrt(norm2), o[..., 4:] + np.log(norm2)], axis=-1)

    def defect(self, o):
        return np.expm1(o[..., 4])


class MatrixPrinted(Formulation):
    name, size, orthogonal = "matrix_printed", 9, False
    # R + [phi]_x R differs from exp([phi]_x) R by O(|phi|^2) a step and is not on the group,
    # so no stage correction exists: first order under every stepper (measured 1.0 for
    # symplectic Euler, midpoint, RK4 and the implicit midpoint)
    order_limit = 1
    description = "rotation matrix R + h [w]_x R as the slides print it, no re-orthonormalisation"

    def from_quaternion(self, q):
        r = quaternion_to_matrix(np.asarray(q, float))
        return r.reshape(r.shape[:-2] + (9,))

    def matrix(self, o):
        return o.reshape(o.shape[:-1] + (3, 3))

    def quaternion(self, o):
        return matrix_to_quaternion(polar_factor(self.matrix(o)))

    def _euler_step(self, o, phi):
        r = self.matrix(o)
        return r + skew(phi) @ r

    def shift(self, o, phi):
        return self._euler_step(o, phi).reshape(o.shape)

    def defect(self, o):
        r = self.matrix(o)
        gram = np.swapaxes(r, -1, -2) @ r - np.eye(3)
        return np.max(np.abs(gram), axis=(-2, -1))


class MatrixPolar(MatrixPrinted):
    name, orthogonal = "matrix_polar", True
    order_limit = None  # the polar factor is exp(atan|phi| axis): back on the group
    description = ("rotation matrix R + h [w]_x R re-orthonormalised to its polar factor "
                   "(SVD U V^T)")
    dinv = staticmethod(dpolar_inverse)

    def shift(self, o, phi):
        return polar_factor(self._euler_step(o, phi)).reshape(o.shape)


FORMULATIONS = {f.name: f for f in (QuaternionExp(), QuaternionNormalised(), MatrixPrinted(),
                                    MatrixPolar())}


def get_formulation(name: str) -> Formulation:
    if name not in FORMULATIONS:
        raise ValueError(f"formulation must be one of {list(FORMULATIONS)}, got {name!r}")
    return FORMULATIONS[name]
