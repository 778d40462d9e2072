"""Small-matrix helpers of the P1 finite elements, vectorised over elements: arrays (..., d, d)
stored component by component (memory (d, d, ...): each entry a[..., i, j] one contiguous run
over the elements, so a closed form written entry by entry is one pass per operation),
traces, the cofactor matrix and its differential, and the rotation-variant SVD.
"""
from __future__ import annotations

import numpy as np


def components(a):
    """(d, d, ...) view of an (..., d, d) array: component [i, j] is a[..., i, j] (contiguous
    where `a` was made by `by_components`)."""
    return np.moveaxis(a, (-2, -1), (0, 1))


def by_components(d, shape):
    """An uninitialised float64 array of shape shape + (d, d) whose components a[..., i, j] are
    contiguous: memory (d, d) + shape."""
    return np.moveaxis(np.empty((d, d) + tuple(shape)), (0, 1), (-2, -1))


def transposed(a):
    return np.swapaxes(a, -1, -2)


def trace(a):
    return np.trace(a, axis1=-2, axis2=-1)


def ddot(a, b):
    return np.sum(a * b, axis=(-2, -1))


def identity(d):
    return np.eye(d)


def new_like(f):
    """(P, its components): a new array shaped as F with component-wise memory."""
    p = by_components(f.shape[-1], f.shape[:-2])
    return p, components(p)


def trace_minus(fc, d, shift):
    """sum_k (F_kk - shift) in k order (shift 1: tr(eps) of the diagonal F_kk - 1)."""
    tr = fc[0, 0] - shift
    for k in range(1, d):
        tr += fc[k, k] - shift
    return tr


def rotation_variant_svd(f):
    """U, s, Vt of F with det U = det V = 1: the last singular value carries det F's sign."""
    u, s, vt = np.linalg.svd(f)
    flip = np.linalg.det(u) * np.linalg.det(vt) < 0
    if np.any(flip):
        u, s = u.copy(), s.copy()
        u[flip, :, -1] *= -1.0
        s[flip, -1] *= -1.0
    return u, s, vt


def cofactor(f):
    """cof F = J F^-T: 2D [[f11, -f10], [-f01, f00]]; 3D columns (c1 x c2, c2 x c0, c0 x c1)
    of F's columns c_k. Linear in F in 2D, quadratic in 3D."""
    if f.shape[-1] == 2:
        return np.stack([np.stack([f[..., 1, 1], -f[..., 1, 0]], -1),
                         np.stack([-f[..., 0, 1], f[..., 0, 0]], -1)], -2)
    c = [f[..., :, k] for k in range(3)]
    return np.stack([np.cross(c[1], c[2]), np.cross(c[2], c[0]), np.cross(c[0], c[1])], -1)


def cofactor_differential(f, df):
    """d(cof F) in the direction dF."""
    if f.shape[-1] == 2:
        return cofactor(df)
    c = [f[..., :, k] for k in range(3)]
    dc = [df[..., :, k] for k in range(3)]
    pairs = ((1, 2), (2, 0), (0, 1))
    return np.stack([np.cross(dc[i], c[j]) + np.cross(c[i], dc[j]) for i, j in pairs], -1)

