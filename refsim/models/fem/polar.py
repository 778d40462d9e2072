"""The corotated law's rotation entry by entry (refsim.models.fem.laws.Corotated's stress on
the explicit force path): the 2D closed form, and in 3D Newton's polar iteration, both one pass
per operation over the elements' contiguous entries (refsim.models.fem.tensors' layout), where
a batched SVD costs a LAPACK call per element.
"""
from __future__ import annotations

import numpy as np

from .tensors import components, new_like


def plane_corotated_stress(f, mu, lam):
    """The 2D corotated stress P = 2 mu (F - R) + lam (tr S - 2) R entry by entry: with (x, y) =
    (F00 + F11, F10 - F01), r = |(x, y)| = tr S and (c, s) = (x, y) / r, P = 2 mu F + g R,
    g = lam (r - 2) - 2 mu, i.e. g c = (lam - 2 (lam + mu) / r) x (R = I, c = 1, where r = 0);
    r as sqrt(x^2 + y^2) (np.hypot: 25x slower here, an ulp apart)."""
    fc = components(f)
    x, y = fc[0, 0] + fc[1, 1], fc[1, 0] - fc[0, 1]
    r = x * x
    r += y * y
    np.sqrt(r, out=r)
    with np.errstate(invalid="ignore", divide="ignore"):  # r = 0: fixed below
        g = np.divide(-2.0 * (lam + mu), r)  # g / r = lam - 2 (lam + mu) / r
        g += lam
        x *= g  # g c = (g / r) x
        y *= g  # g s = (g / r) y
    if not r.all():  # R = I where r = 0: g c = g, g s = 0
        zero = r == 0.0
        x[zero], y[zero] = -2.0 * (lam + mu), 0.0
    p, pc = new_like(f)
    two_mu = 2.0 * mu
    for i, j in ((0, 0), (1, 1), (1, 0), (0, 1)):
        np.multiply(fc[i, j], two_mu, out=pc[i, j])
    pc[0, 0] += x
    pc[1, 1] += x
    pc[1, 0] += y
    pc[0, 1] -= y
    return p


def cofactor_entries(fc):
    """(3, 3, ...) cof F of F's entries fc (3, 3, ...), entry by entry: cof_ij = F_i1j1 F_i2j2 -
    F_i1j2 F_i2j1 with i1, i2 (j1, j2) the next two indices cyclically."""
    cof = np.empty(fc.shape)
    for i in range(3):
        i1, i2 = (i + 1) % 3, (i + 2) % 3
        for j in range(3):
            j1, j2 = (j + 1) % 3, (j + 2) % 3
            np.multiply(fc[i1, j1], fc[i2, j2], out=cof[i, j])
            cof[i, j] -= fc[i1, j2] * fc[i2, j1]
    return cof


POLAR_SCALED = 1e-2  # Higham's scaling while an update moves an entry of X by more than this
POLAR_CONVERGED = 1e-8  # then one more iteration: quadratic, its update ~1e-16 (R entries <= 1)
POLAR_MAX_ITERATIONS = 40


def newton_polar(fc):
    """(R's entries (3, 3, m), converged (m,) bool) of F's entries fc (3, 3, m), det F > 0: the
    orthogonal polar factor by Newton's iteration X <- (z X + X^-T / z) / 2, X^-T = cof X /
    det X, from X = F, with Higham's (1986) scaling z = (|X^-1|_F / |X|_F)^(1/2) while an
    update moves an entry by more than POLAR_SCALED (z = 1 after); it converges quadratically
    to the rotation of F = R S, the SVD's U V^T. All elements iterate until the largest update
    of an entry is at most POLAR_CONVERGED, then once more; an element whose last update is
    larger (or any, after POLAR_MAX_ITERATIONS) is reported for another method."""
    x = np.array(fc, dtype=float, order="C")  # (3, 3, m) contiguous whatever F's layout
    scaled, final = True, False
    for _ in range(POLAR_MAX_ITERATIONS):
        cof = cofactor_entries(x)
        det = x[0, 0] * cof[0, 0]
        for k in (1, 2):
            det += x[0, k] * cof[0, k]
        if scaled:
            z = np.sqrt(np.sqrt(np.einsum("ij...,ij...->...", cof, cof) / np.einsum(
                "ij...,ij...->...", x, x)) / np.abs(det))
            new = cof * (1.0 / (z * det))
            new += x * z
        else:
            new = cof * (1.0 / det)
            new += x
        new *= 0.5
        x -= new
        np.abs(x, out=x)
        update = x.max(axis=(0, 1))
        x = new
        step = update.max()
        if final or step != step:  # done, or NaN: those elements go to the SVD
            break
        scaled, final = step > POLAR_SCALED, step <= POLAR_CONVERGED
    return x, update <= POLAR_CONVERGED


def spatial_corotated_stress(f, mu, lam, svd_stress):
    """The 3D corotated stress P = 2 mu (F - R) + lam (tr S - 3) R, tr S = R : F, with R by
    `newton_polar` where det F > 0 (there F = R S with S positive definite is unique, so R is
    the rotation-variant SVD's U V^T); elsewhere (inverted or collapsed elements, where the
    rotation-variant SVD flips the smallest singular value) and wherever Newton has not
    converged, `svd_stress` of those elements."""
    fc = components(f)
    det = fc[0, 0] * (fc[1, 1] * fc[2, 2] - fc[1, 2] * fc[2, 1])
    det -= fc[0, 1] * (fc[1, 0] * fc[2, 2] - fc[1, 2] * fc[2, 0])
    det += fc[0, 2] * (fc[1, 0] * fc[2, 1] - fc[1, 1] * fc[2, 0])
    upright = det > 0.0
    if not upright.any():
        return svd_stress(f)
    every = bool(upright.all())
    sub = fc if every else fc[:, :, upright]
    r, ok = newton_polar(sub)
    stretch = r[0, 0] * sub[0, 0]
    for i in range(3):
        for j in range(3):
            if i or j:
                stretch += r[i, j] * sub[i, j]
    stretch -= 3.0
    stretch *= lam
    two_mu = 2.0 * mu
    p, pc = new_like(f)
    out = np.empty(r.shape)
    for i in range(3):
        for j in range(3):
            np.subtract(sub[i, j], r[i, j], out=out[i, j])
            out[i, j] *= two_mu
            out[i, j] += stretch * r[i, j]
    if every:
        pc[...] = out
    else:
        pc[:, :, upright] = out
    redo = ~upright
    if not ok.all():
        redo[np.flatnonzero(upright)[~ok]] = True
    if redo.any():
        p[redo] = svd_stress(f[redo])
    return p
