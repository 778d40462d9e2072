"""Grid signed distance fields (slide 001: depth phi, normal grad phi): the exact SDF of an
analytic shape at the origin sampled on a node grid, and its trilinear interpolant with the
interpolant's own gradient, vectorised over the probes (no Python loop over probes or nodes).

Exact signed distances (negative inside), written on coordinate arrays that broadcast (the
node grid's three axes, or the probes' columns):
- sphere, radius a: phi = |x| - a, grad phi = x / |x| (singular at the centre);
- box, half extents b: q = |x| - b (componentwise), phi = |max(q, 0)| + min(max_i q_i, 0);
  grad phi = sign(x) max(q, 0) / |max(q, 0)| outside, sign(x_k) e_k inside with k = argmax q
  (singular on the inner medial surfaces, where two faces are nearest, and kinked along the
  edges and corners);
- torus about z, radii R (core circle) and r (tube): rho = sqrt(x^2 + y^2),
  d = sqrt((rho - R)^2 + z^2), phi = d - r, grad phi = ((rho - R) (x, y) / rho, z) / d
  (singular on the core circle and on the z axis).

The grid: nodes x_ijk = lower + h (i, j, k), values stored (nx, ny, nz) (axis 0 is x). The
interpolant on the cell [x_i, x_i+1] x ... with t = (x - x_ijk) / h in [0, 1]^3 is
phi_h = sum over the 8 corners of prod_a (t_a or 1 - t_a) phi_corner, evaluated as nested
linear interpolations (x, then y, then z); its gradient is the exact derivative of that
polynomial: d phi_h / dz = (c1 - c0) / h of the two xy-bilinear values, d / dy the z-linear
blend of the y differences, d / dx the yz-bilinear blend of the four x-edge differences
(piecewise bilinear in the other two coordinates, discontinuous across cell faces). A probe
on an inner cell face takes the cell above it (floor), one on the grid's upper boundary the
last cell (t = 1).
"""
from __future__ import annotations

import numpy as np

SHAPES = ("sphere", "box", "torus")


def signed_distance(shape: str, size, x, y, z) -> np.ndarray:
    """The exact SDF at points given by broadcastable coordinate arrays x, y, z."""
    size = np.asarray(size, float)
    if shape == "sphere":
        return np.sqrt(x * x + y * y + z * z) - size[0]
    if shape == "box":
        qx, qy, qz = np.abs(x) - size[0], np.abs(y) - size[1], np.abs(z) - size[2]
        ox, oy, oz = np.maximum(qx, 0.0), np.maximum(qy, 0.0), np.maximum(qz, 0.0)
        outside = np.sqrt(ox * ox + oy * oy + oz * oz)
        return outside + np.minimum(np.maximum(np.maximum(qx, qy), qz), 0.0)
    if shape == "torus":
        rho = np.sqrt(x * x + y * y)
        return np.hypot(rho - size[0], z) - size[1]
    raise ValueError(f"sdf shape must be one of {list(SHAPES)}, got {shape!r}")


def gradient(shape: str, size, points) -> np.ndarray:
    """(m, 3) exact grad phi at (m, 3) points (off the singular set)."""
    p = np.asarray(points, float)
    size = np.asarray(size, float)
    if shape == "sphere":
        return p / np.linalg.norm(p, axis=1)[:, None]
    if shape == "box":
        q = np.abs(p) - size
        sign = np.where(p < 0, -1.0, 1.0)
        out = np.maximum(q, 0.0)
        norm = np.linalg.norm(out, axis=1)
        inside = np.zeros_like(p)
        inside[np.arange(len(p)), np.argmax(q, axis=1)] = 1.0
        with np.errstate(invalid="ignore", divide="ignore"):
            g = np.where((norm > 0)[:, None], out / norm[:, None], inside)
        return sign * g
    if shape == "torus":
        rho = np.hypot(p[:, 0], p[:, 1])
        radial = rho - size[0]
        d = np.hypot(radial, p[:, 2])
        g = np.empty_like(p)
        g[:, 0] = radial * p[:, 0] / rho / d
        g[:, 1] = radial * p[:, 1] / rho / d
        g[:, 2] = p[:, 2] / d
        return g
    raise ValueError(f"sdf shape must be one of {list(SHAPES)}, got {shape!r}")


def exact(shape: str, size, points) -> tuple[np.ndarray, np.ndarray]:
    """(phi (m,), grad (m, 3)) of the exact SDF at (m, 3) points."""
    p = np.asarray(points, float)
    return signed_distance(shape, size, p[:, 0], p[:, 1], p[:, 2]), gradient(shape, size, p)


def node_axes(lower, h: float, nodes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The node coordinates as three broadcastable axes: (nx,1,1), (1,ny,1), (1,1,nz)."""
    lower = np.asarray(lower, float)
    return tuple(np.reshape(lower[a] + h * np.arange(nodes[a]),
                            [-1 if b == a else 1 for b in range(3)]) for a in range(3))


def sample(shape: str, size, lower, h: float, nodes, dtype=np.float64) -> np.ndarray:
    """(nx, ny, nz) exact SDF at the nodes lower + h (i, j, k), stored as `dtype`."""
    x, y, z = node_axes(lower, h, nodes)
    return np.ascontiguousarray(signed_distance(shape, size, x, y, z), dtype=dtype)


def cells(lower, h: float, nodes, points) -> tuple[np.ndarray, np.ndarray]:
    """(index (m, 3) int of each probe's cell's lower node, t (m, 3) in [0, 1]): floor,
    clipped to the grid's last cell."""
    u = (np.asarray(points, float) - np.asarray(lower, float)) / h
    index = np.clip(np.floor(u).astype(np.int64), 0, np.asarray(nodes) - 2)
    return index, u - index


def trilinear(values: np.ndarray, lower, h: float, points) -> tuple[np.ndarray, np.ndarray]:
    """(phi_h (m,), grad phi_h (m, 3)) of the trilinear interpolant of the node values
    `values` (nx, ny, nz) at (m, 3) points inside the grid."""
    _, ny, nz = values.shape
    index, t = cells(lower, h, values.shape, points)
    flat = values.reshape(-1)
    sx, sy = ny * nz, nz
    base = (index[:, 0] * ny + index[:, 1]) * nz + index[:, 2]
    c000, c100 = flat[base], flat[base + sx]
    c010, c110 = flat[base + sy], flat[base + sx + sy]
    c001, c101 = flat[base + 1], flat[base + sx + 1]
    c011, c111 = flat[base + sy + 1], flat[base + sx + sy + 1]
    tx, ty, tz = t[:, 0], t[:, 1], t[:, 2]
    dx00, dx10, dx01, dx11 = c100 - c000, c110 - c010, c101 - c001, c111 - c011
    c00, c10 = c000 + tx * dx00, c010 + tx * dx10
    c01, c11 = c001 + tx * dx01, c011 + tx * dx11
    dy0, dy1 = c10 - c00, c11 - c01
    c0, c1 = c00 + ty * dy0, c01 + ty * dy1
    phi = c0 + tz * (c1 - c0)
    ex0, ex1 = dx00 + ty * (dx10 - dx00), dx01 + ty * (dx11 - dx01)
    grad = np.empty((len(t), 3), dtype=np.result_type(values.dtype, t.dtype))
    grad[:, 0] = (ex0 + tz * (ex1 - ex0)) / h
    grad[:, 1] = (dy0 + tz * (dy1 - dy0)) / h
    grad[:, 2] = (c1 - c0) / h
    return phi, grad
