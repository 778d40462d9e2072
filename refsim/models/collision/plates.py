"""Sphere contacts with thin static plates (square slabs, refsim.scene.Plates), vectorised over
spheres x plates (no Python loop over either): discrete overlaps with the push-out side made
explicit, and the time of impact of a sphere's centre path with the slab's faces.

A plate: mid-plane centre c, unit normal n, thickness w, half side H. A sphere of radius r with
centre x, d = (x - c).n, touches it where |d| < w/2 + r and its centre projects into the square
(|q.a|, |q.b| <= H, q = x - c - d n, (a, b) the in-plane axes of `plate_axes`). Only the faces
are modelled: a sphere reaching past the rim touches nothing (no edge or corner contacts).

Conventions (those of the walls in refsim.models.collisions): a contact is (sphere s, plate k,
unit normal m from the plate towards the sphere, depth = how far along m the centre must move to
touch); m = side n, side = +1 or -1 the face the sphere is pushed out of.
"""
from __future__ import annotations

import numpy as np

PUSH_SIDES = ("approach", "nearest")


def plate_axes(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal in-plane axes (a, b), each (p, 3), of unit normals (p, 3): a = n x e / |n x e|
    with e the coordinate axis least aligned with n, b = n x a."""
    normal = np.asarray(normal, float)
    e = np.eye(3)[np.argmin(np.abs(normal), axis=1)]
    a = np.cross(normal, e)
    a /= np.linalg.norm(a, axis=1)[:, None]
    return a, np.cross(normal, a)


def _in_square(q, a, b, half_size):
    """q (s, p, 3) in-plane offsets: inside the squares of half side (p,)?"""
    qa = np.abs(np.einsum("spk,pk->sp", q, a))
    qb = np.abs(np.einsum("spk,pk->sp", q, b))
    return (qa <= half_size) & (qb <= half_size)


def _sign(values, zero_as):
    return np.where(values > 0, 1.0, np.where(values < 0, -1.0, zero_as))


def plate_contacts(x, radii, center, normal, thickness, half_size, x_before=None, axes=None):
    """Overlaps of spheres (x (s, 3), radii (s,)) with plates at the end of a step: (sphere,
    plate, normal m (k, 3), depth (k,)), depth > 0.

    The push-out side: with `x_before` (the centres at the start of the step) the side the
    centre came from, sign((x_before - c).n) (the rule "approach": a sphere overlapping the
    slab is sent back, even with its centre past the mid-plane: the step tunnels only when it
    misses the slab, v dt >= w + 2 r + the gap); without, the face of least penetration,
    sign((x - c).n) (the rule "nearest": a centre past the mid-plane is pushed through). A
    centre exactly on the mid-plane goes to +n. `axes`: the plates' `plate_axes`, if known."""
    rel = x[:, None, :] - center[None]
    d = np.einsum("spk,pk->sp", rel, normal)
    reach = thickness[None] / 2 + radii[:, None]
    a, b = plate_axes(normal) if axes is None else axes
    touching = (np.abs(d) < reach) & _in_square(rel - d[..., None] * normal[None], a, b,
                                                half_size[None])
    if x_before is None:
        side = _sign(d, 1.0)
    else:
        side = _sign(np.einsum("spk,pk->sp", x_before[:, None, :] - center[None], normal), 1.0)
    s, k = np.nonzero(touching)
    side = side[s, k]
    return s, k, side[:, None] * normal[k], reach[s, k] - side * d[s, k]


def plate_time_of_impact(x, v, radii, center, normal, thickness, half_size, h, axes=None):
    """First contact within [0, h] of spheres moving at constant velocity v (s, 3) with the
    plates' faces: (sphere, plate, normal m (k, 3), tau (k,)).

    A sphere outside the slab's extent (|d| >= w/2 + r) approaching it (d (v.n) < 0) meets the
    face on its side at tau = (|d| - (w/2 + r)) / |v.n|, a contact if tau <= h and its centre
    then projects into the square; one already overlapping and moving towards the mid-plane is
    a contact now (tau = 0), pushed to the side its centre is on. m = sign(d) n."""
    rel = x[:, None, :] - center[None]
    d = np.einsum("spk,pk->sp", rel, normal)
    vn = v @ normal.T
    reach = thickness[None] / 2 + radii[:, None]
    approaching = d * vn < 0
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = np.where(np.abs(d) >= reach, (np.abs(d) - reach) / np.abs(vn), 0.0)
    at_contact = rel + tau[..., None] * v[:, None, :]
    dc = np.einsum("spk,pk->sp", at_contact, normal)
    a, b = plate_axes(normal) if axes is None else axes
    inside = _in_square(at_contact - dc[..., None] * normal[None], a, b, half_size[None])
    s, k = np.nonzero(approaching & (tau <= h) & inside)
    side = _sign(d[s, k], 1.0)
    return s, k, side[:, None] * normal[k], tau[s, k]
