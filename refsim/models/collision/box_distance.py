"""Exact distance between separated oriented boxes, vectorised over the batch (issue 28; used by
refsim.models.collision.sat.box_pairs).

The distance of two disjoint convex polyhedra is attained at a vertex of one and a face, edge
or vertex of the other, or at two edges. So it is the least of: each of the 8 vertices of B
against box A and each of A's against box B (the point-to-box distance ||q - clamp(q, -h, h)||
with q the point in the box's frame: covers faces, edges and vertices at once), and each of
A's 12 edges against each of B's 12 (segment-segment closest points, Ericson, Real-Time
Collision Detection, 2005, sec. 5.1.9: the clamped line parameters, exact for parallel edges
too). Every candidate is the distance of two points of the boxes' surfaces, so none is below
the true distance, and one attains it. The normal is the unit vector from A's closest point to
B's. Coordinates relative to A's centre (smaller magnitudes: less round-off).
"""
from __future__ import annotations

import numpy as np

SIGNS = np.array([[sx, sy, sz] for sx in (-1.0, 1.0) for sy in (-1.0, 1.0)
                  for sz in (-1.0, 1.0)])  # the 8 vertices' sign patterns


def box_vertices(center, half, rot):
    """(n, 8, 3) world vertices c + R (s * h)."""
    return center[:, None, :] + (SIGNS[None] * half[:, None, :]) @ np.swapaxes(rot, 1, 2)


def box_edges(center, half, rot):
    """(start (n, 12, 3), direction (n, 12, 3)): edge = start + s direction, s in [0, 1]."""
    starts, dirs = [], []
    for axis in range(3):
        others = [i for i in range(3) if i != axis]
        for s1 in (-1.0, 1.0):
            for s2 in (-1.0, 1.0):
                local = np.zeros(3)
                local[axis], local[others[0]], local[others[1]] = -1.0, s1, s2
                starts.append(center + np.einsum("nij,nj->ni", rot, local * half))
                dirs.append(2.0 * half[:, axis, None] * rot[:, :, axis])
    return np.stack(starts, axis=1), np.stack(dirs, axis=1)


def _points_to_box(points, center, half, rot):
    """Least distance from the points (n, m, 3) to the solid box: (distance (n,), vector from
    the box's closest point to the point (n, 3), world)."""
    q = (points - center[:, None, :]) @ rot
    r = q - np.clip(q, -half[:, None, :], half[:, None, :])
    d = np.linalg.norm(r, axis=-1)
    i = np.argmin(d, axis=1)
    rows = np.arange(len(points))
    return d[rows, i], np.einsum("nij,nj->ni", rot, r[rows, i])


def _segments(p1, d1, p2, d2):
    """Closest points of segments p1 + s d1 and p2 + t d2 (tuples of x, y, z arrays that
    broadcast), Ericson's clamped form: (squared distance, the vector from the first's closest
    point to the second's as x, y, z)."""
    dot = lambda u, v: u[0] * v[0] + u[1] * v[1] + u[2] * v[2]  # noqa: E731
    r = tuple(x1 - x2 for x1, x2 in zip(p1, p2))
    a, e, b = dot(d1, d1), dot(d2, d2), dot(d1, d2)
    c, f = dot(d1, r), dot(d2, r)
    denom = a * e - b * b
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.where(denom > 0, np.clip((b * f - c * e) / denom, 0.0, 1.0), 0.0)
    t = (b * s + f) / e
    s = np.where(t < 0, np.clip(-c / a, 0.0, 1.0), np.where(t > 1, np.clip((b - c) / a, 0.0, 1.0),
                                                           s))
    t = np.clip(t, 0.0, 1.0)
    w = tuple(r2 + t * v2 - r1 - s * v1 for r1, v1, r2, v2 in zip(p1, d1, p2, d2))
    return dot(w, w), w


def box_distance(a_center, a_half, a_rot, b_center, b_half, b_rot):
    """(distance (n,), unit normal from A to B (n, 3)) of separated boxes (exact to round-off;
    for overlapping boxes the distance returned is 0, the boxes' surfaces may still be apart)."""
    bc = b_center - a_center
    ac = np.zeros_like(a_center)
    best, vec = _points_to_box(box_vertices(bc, b_half, b_rot), ac, a_half, a_rot)  # A -> B
    d_ab, v_ab = _points_to_box(box_vertices(ac, a_half, a_rot), bc, b_half, b_rot)  # B -> A
    closer = d_ab < best
    best, vec = np.where(closer, d_ab, best), np.where(closer[:, None], -v_ab, vec)
    best2 = best * best
    pa, da = (tuple(np.ascontiguousarray(x[..., k]) for k in range(3))
              for x in box_edges(ac, a_half, a_rot))
    pb, db = (tuple(np.ascontiguousarray(x[..., k]) for k in range(3))
              for x in box_edges(bc, b_half, b_rot))
    rows = np.arange(len(bc))
    for i in range(12):  # A's edge i against B's 12 edges, the batch at once
        d2, w = _segments(tuple(x[:, i:i + 1] for x in pa), tuple(x[:, i:i + 1] for x in da),
                          pb, db)
        j = np.argmin(d2, axis=1)
        dj = d2[rows, j]
        closer = dj < best2
        if closer.any():
            best2 = np.where(closer, dj, best2)
            vec = np.where(closer[:, None], np.stack([x[rows, j] for x in w], -1), vec)
    best = np.sqrt(best2)
    with np.errstate(invalid="ignore", divide="ignore"):
        return best, vec / np.linalg.norm(vec, axis=1)[:, None]
