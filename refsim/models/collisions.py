"""Sphere contacts, vectorised: uniform-grid broad phase, narrow phase, impulse response with
restitution and Coulomb friction, positional projection, time of impact, and the course
slide's hard-sphere update. No Python loop over spheres or pairs.

Conventions: a pair (i, j) has unit normal n from i to j; the impulse P acts on j and -P on i.
"""
from __future__ import annotations

import numpy as np

# the forward neighbour offsets of a cell (13 in 3D, 4 in 2D: a positive first non-zero
# component), plus the cell itself: every unordered pair of neighbouring cells is visited once
_OFFSETS = {3: np.array([(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)
                         if (a, b, c) > (0, 0, 0)] + [(0, 0, 0)]),
            2: np.array([(a, b, 0) for a in (-1, 0, 1) for b in (-1, 0, 1)
                         if (a, b) > (0, 0)] + [(0, 0, 0)])}
_FULL = {3: np.array([(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)]),
         2: np.array([(a, b, 0) for a in (-1, 0, 1) for b in (-1, 0, 1)])}


def _pad3(x):
    return x if x.shape[1] == 3 else np.column_stack([x, np.zeros(len(x))])


def _cell_keys(x, cell, origin):
    return np.floor((_pad3(x) - origin) / cell).astype(np.int64) + 1  # >= 1 for -1 offsets


def _pairs_by_cells(query_keys, target_keys, offsets, dims):
    """(query index, target index) for every target point in the cells at `offsets` from each
    query point's cell: targets sorted by cell id, ranges found with searchsorted, expanded
    with repeat (no Python loop over points)."""
    def cell_id(keys):
        return (keys[:, 0] * dims[1] + keys[:, 1]) * dims[2] + keys[:, 2]
    order = np.argsort(cell_id(target_keys), kind="stable")
    sorted_cid = cell_id(target_keys)[order]
    firsts, seconds = [], []
    for off in offsets:
        nb = cell_id(query_keys + off)
        start = np.searchsorted(sorted_cid, nb, side="left")
        counts = np.searchsorted(sorted_cid, nb, side="right") - start
        total = int(counts.sum())
        if total:
            i = np.repeat(np.arange(len(query_keys)), counts)
            ranges = np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
            firsts.append(i)
            seconds.append(order[np.repeat(start, counts) + ranges])
        else:
            firsts.append(np.zeros(0, int))
            seconds.append(np.zeros(0, int))
    return firsts, seconds


def grid_pairs(x: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Candidate pairs of 2D or 3D points closer than `cell` (and some farther), each once:
    points are sorted by cell id, and each point meets the points of its own cell and of the
    forward neighbour cells. O(N log N) for the sort, O(N) for the rest at bounded density.
    """
    dim = x.shape[1]
    origin = _pad3(x).min(axis=0)
    keys = _cell_keys(x, cell, origin)
    dims = keys.max(axis=0) + 2
    firsts, seconds = _pairs_by_cells(keys, keys, _OFFSETS[dim], dims)
    own_i, own_j = firsts[-1], seconds[-1]  # the last offset is the cell itself
    keep = own_i < own_j
    firsts[-1], seconds[-1] = own_i[keep], own_j[keep]
    return np.concatenate(firsts), np.concatenate(seconds)


def grid_cross_pairs(a: np.ndarray, b: np.ndarray, cell: float):
    """Candidate pairs (i in a, j in b) closer than `cell`: each point of a meets the points
    of b in its own and all neighbouring cells."""
    dim = a.shape[1]
    both = np.concatenate([_pad3(a), _pad3(b)])
    origin = both.min(axis=0)
    ka, kb = _cell_keys(a, cell, origin), _cell_keys(b, cell, origin)
    dims = np.maximum(ka.max(axis=0), kb.max(axis=0)) + 2
    firsts, seconds = _pairs_by_cells(ka, kb, _FULL[dim], dims)
    return np.concatenate(firsts), np.concatenate(seconds)


def all_pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Every pair, for a handful of spheres (cheaper than a grid below ~16 spheres)."""
    i, j = np.triu_indices(n, k=1)
    return i, j


def candidate_pairs(x, radii, margin=0.0):
    reach = 2.0 * float(np.max(radii)) + margin
    return all_pairs(len(x)) if len(x) < 16 else grid_pairs(x, reach)


def sphere_contacts(x, radii, i, j, margin=0.0):
    """Pairs closer than r_i + r_j + margin: (i, j, unit normal i->j, depth = r_i + r_j - d)."""
    d = x[j] - x[i]
    dist = np.sqrt(np.einsum("ij,ij->i", d, d))
    reach = radii[i] + radii[j]
    hit = dist < reach + margin
    i, j, d, dist, reach = i[hit], j[hit], d[hit], dist[hit], reach[hit]
    n = d / np.where(dist > 0, dist, 1.0)[:, None]
    return i, j, n, reach - dist


def wall_contacts(x, radii, points, normals, margin=0.0):
    """(sphere, wall, depth = r - signed distance) for spheres within r + margin of a wall."""
    dist = np.einsum("swk,wk->sw", x[:, None, :] - points[None], normals)
    depth = radii[:, None] - dist
    s, w = np.nonzero(depth > -margin)
    return s, w, depth[s, w]


def _scatter(target, index, values):
    """target[index] += values with repeated indices summed (per component)."""
    for k in range(target.shape[1]):
        target[:, k] += np.bincount(index, weights=values[:, k], minlength=len(target))


def resolve_pairs(v, w, inv_m, inv_i, radii, i, j, n, e, mu, max_iter=1000, tol=1e-12):
    """Impulses for approaching sphere pairs, in passes until none approaches.

    Each pass applies impulses to a set of approaching pairs that share no sphere (for each
    sphere, the first approaching pair it appears in; at least one pair per pass), so every
    applied impulse is an exact two-body impact: energy is conserved at e = 1 even when a
    sphere touches several others (a Jacobi pass over shared spheres would not conserve it).

    Normal: P_n = -(1 + e) (u . n) / (1/m_i + 1/m_j), u the relative velocity of j's contact
    point with respect to i's (Newton's restitution law). Tangential (mu > 0): the impulse that
    stops sliding, |u_t| / k_t with k_t = 1/m_i + 1/m_j + r_i^2/I_i + r_j^2/I_j, if it is within
    mu P_n (stick), else mu P_n against the sliding direction (Guendelman, Bridson & Fedkiw,
    SIGGRAPH 2003). Every impulse acts equally and oppositely: momentum is conserved to
    round-off, whatever the number of passes. Returns the passes used.
    """
    if len(i) == 0:
        return 0
    ri, rj = radii[i][:, None] * n, -radii[j][:, None] * n  # centre -> contact point
    k_n = inv_m[i] + inv_m[j]
    k_t = k_n + radii[i] ** 2 * inv_i[i] + radii[j] ** 2 * inv_i[j]
    for passes in range(1, max_iter + 1):
        u = (v[j] + np.cross(w[j], rj)) - (v[i] + np.cross(w[i], ri))
        un = np.einsum("pk,pk->p", u, n)
        act = un < -tol * (1.0 + np.abs(un))
        if not act.any():
            return passes - 1
        act &= _disjoint(i, j, act, len(v))
        impulse = _contact_impulse(u, un, n, act, e, k_n, k_t, mu)
        _apply(v, w, inv_m, inv_i, i, j, ri, rj, impulse)
    return max_iter


def _contact_impulse(u, un, n, act, e, k_n, k_t, mu):
    """Impulse of active contacts: Newton's restitution along n, and (mu > 0) the Coulomb
    stick/slide tangential part, min(|u_t| / k_t, mu P_n) against the sliding direction."""
    pn = np.where(act, -(1.0 + e) * un / k_n, 0.0)
    impulse = pn[:, None] * n
    if mu > 0:
        ut = u - un[:, None] * n
        slide = np.sqrt(np.einsum("pk,pk->p", ut, ut))
        tdir = ut / np.where(slide > 0, slide, 1.0)[:, None]
        pt = np.where(act, np.minimum(slide / k_t, mu * pn), 0.0)
        impulse = impulse - pt[:, None] * tdir
    return impulse


def _disjoint(i, j, act, n):
    """Mask of active pairs that are the first active pair of both their spheres."""
    idx = np.flatnonzero(act)
    spheres = np.concatenate([i[idx], j[idx]])
    owners = np.concatenate([idx, idx])
    first = np.full(n, -1)
    order = np.argsort(owners, kind="stable")[::-1]  # later pairs first, earliest wins last
    first[spheres[order]] = owners[order]
    mask = np.zeros(len(i), bool)
    mask[idx] = (first[i[idx]] == idx) & (first[j[idx]] == idx)
    return mask


def _apply(v, w, inv_m, inv_i, i, j, ri, rj, impulse):
    _scatter(v, j, inv_m[j][:, None] * impulse)
    _scatter(v, i, -inv_m[i][:, None] * impulse)
    _scatter(w, j, inv_i[j][:, None] * np.cross(rj, impulse))
    _scatter(w, i, -inv_i[i][:, None] * np.cross(ri, impulse))


def resolve_walls(v, w, masses, inv_i, radii, s, wall_normals, e, mu, tol=1e-12):
    """Impulses of fixed walls on approaching spheres (infinite wall mass); returns the total
    impulse the walls gave (a 3-vector), so momentum can be balanced."""
    if len(s) == 0:
        return np.zeros(3)
    n = wall_normals
    r = -radii[s][:, None] * n  # centre -> contact point
    u = v[s] + np.cross(w[s], r)
    un = np.einsum("pk,pk->p", u, n)
    act = un < -tol * (1.0 + np.abs(un))
    inv_m = 1.0 / masses[s]
    impulse = _contact_impulse(u, un, n, act, e, inv_m, inv_m + radii[s] ** 2 * inv_i[s], mu)
    _scatter(v, s, inv_m[:, None] * impulse)
    _scatter(w, s, inv_i[s][:, None] * np.cross(r, impulse))
    return impulse.sum(axis=0)


def project_pairs(x, inv_m, i, j, n, depth):
    """Move overlapping pairs apart along n by their depth, shared by inverse mass (one Jacobi
    pass; positions only, so momentum and energy are untouched)."""
    share = depth / (inv_m[i] + inv_m[j])
    _scatter(x, j, (share * inv_m[j])[:, None] * n)
    _scatter(x, i, -(share * inv_m[i])[:, None] * n)


def project_walls(x, s, wall_normals, depth):
    _scatter(x, s, np.maximum(depth, 0.0)[:, None] * wall_normals)


def time_of_impact(dx, dv, reach, h):
    """Earliest tau in [0, h] with |dx + dv tau| = reach for approaching pairs; NaN if none."""
    a = np.einsum("pk,pk->p", dv, dv)
    b = np.einsum("pk,pk->p", dx, dv)
    c = np.einsum("pk,pk->p", dx, dx) - reach ** 2
    disc = b * b - a * c
    with np.errstate(invalid="ignore", divide="ignore"):
        tau = (-b - np.sqrt(disc)) / a
    ok = (a > 0) & (b < 0) & (disc >= 0) & (tau <= h)
    tau = np.where(c <= 0, 0.0, tau)  # already touching: now
    return np.where(ok | ((c <= 0) & (b < 0)), np.clip(tau, 0.0, h), np.nan)


def hard_sphere_seed(v, x, masses, i, j):
    """The slide's hard-sphere update, exactly as printed (deck 000,
    docs/sources.md#deck-000-physically-based-animation-mpri-2-39, slide "Particles: Hard sphere"):

        v1' = v1 + 1/(m1+m2) [ m2 <v2,u> - 1/2 (m1 + 3 m2) <v1,u> ] u
        v2' = v2 + 1/(m1+m2) [ m1 <v1,u> - 1/2 (m2 + 3 m1) <v2,u> ] u,   u = x1 - x0

    with x0 read as the other sphere's centre (the slide numbers the spheres 1 and 2, so x0
    can only be x2) and u left unnormalised, as printed. Both spheres use the old velocities.
    """
    u = x[i] - x[j]
    m1, m2 = masses[i], masses[j]
    v1u = np.einsum("pk,pk->p", v[i], u)
    v2u = np.einsum("pk,pk->p", v[j], u)
    d1 = (m2 * v2u - 0.5 * (m1 + 3 * m2) * v1u) / (m1 + m2)
    d2 = (m1 * v1u - 0.5 * (m2 + 3 * m1) * v2u) / (m1 + m2)
    _scatter(v, i, d1[:, None] * u)
    _scatter(v, j, d2[:, None] * u)
