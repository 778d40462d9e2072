"""Neighbour pairs within a radius by a cell list: 2D and 3D, open or periodic (minimum image),
vectorised over particles, cells and any leading batch axes.

`neighbour_pairs(x, radius, box)` bins the positions (..., n, d) into cells of side >= radius,
sorts them by cell, then makes ONE vectorised pass per neighbour-cell offset (3^d of them: the
cell itself and its 8 or 26 neighbours): every particle meets every particle of the cell at that
offset from its own, the candidates are filtered to i < j and |x_j - x_i| < radius. A pair
within the radius lies in adjacent cells (side >= radius), and it is met from i's side at
exactly one offset, so it is found exactly once. The loop is over offsets (9 or 27), never over
particles or cells. Batch instances get disjoint cell ids, so they never pair.

Periodic boxes: positions are wrapped into [0, L) for binning, with floor(L / radius) cells per
axis; offsets that coincide modulo a short axis (fewer than 3 cells) are taken once. The
separation is the minimum image x_j - x_i - L round((x_j - x_i) / L), which is the one image
within the radius when L >= 2 radius (the LennardJones part's rule). Open space: a grid over
the bounding box, its cells enlarged beyond `radius` where the box is so sparse that there
would be more than 4 cells per particle (bounded memory for scattered points).

`all_pairs(x)` is the brute force (every i < j of an instance), for an infinite radius and the
tests. Both return (i, j, sep): i, j flat indices into x.reshape(-1, d) (instance b's particle
k is b n + k), i < j, and sep (m, d) = x_j - x_i (minimum image in a periodic box).
"""
from __future__ import annotations

import itertools
import math

import numpy as np

MAX_CELLS_PER_PARTICLE = 4  # open space: the grid's cell count is capped at 4 n


def all_pairs(x, box=None):
    """Every pair i < j of each instance of x (..., n, d): (i, j, sep) as neighbour_pairs."""
    x = np.asarray(x, float)
    n, d = x.shape[-2], x.shape[-1]
    flat = x.reshape(-1, d)
    batch = flat.shape[0] // max(n, 1)
    i0, j0 = np.triu_indices(n, k=1)
    shift = (np.arange(batch) * n)[:, None]
    i, j = (i0 + shift).reshape(-1), (j0 + shift).reshape(-1)
    sep = flat[j] - flat[i]
    if box is not None:
        lengths = np.asarray(box, float)
        sep -= lengths * np.round(sep / lengths)
    return i, j, sep


def _grid(flat, radius, box):
    """(cells per axis (d,) int, cell side (d,), origin (d,), positions to bin (m, d))."""
    d = flat.shape[1]
    if box is not None:
        lengths = np.asarray(box, float)
        cells = np.maximum(np.floor(lengths / radius), 1).astype(np.int64)
        return cells, lengths / cells, np.zeros(d), np.mod(flat, lengths)
    origin = flat.min(axis=0) if len(flat) else np.zeros(d)
    extent = (flat.max(axis=0) - origin) if len(flat) else np.zeros(d)
    side = radius
    volume = float(np.prod(np.maximum(extent, radius)))
    if volume / radius ** d > MAX_CELLS_PER_PARTICLE * max(len(flat), 1):
        side = (volume / (MAX_CELLS_PER_PARTICLE * max(len(flat), 1))) ** (1.0 / d)
    cells = np.maximum(np.floor(extent / side), 1).astype(np.int64)
    cell_side = np.where(extent > 0, extent / cells, 1.0)
    return cells, cell_side, origin, flat


def _offsets(cells, periodic):
    """(offsets (k, d), half): the neighbour-cell offsets. A half shell (the cell itself and
    the offsets whose first non-zero component is +1: 5 in 2D, 14 in 3D) when every offset
    reaches a distinct cell, so each pair of cells is visited once; else (a periodic axis of
    fewer than 3 cells) the full shell {-1, 0, 1}^d with those equal modulo the axis taken
    once, each pair then met from both sides and kept from i's side (i < j)."""
    full = np.array(list(itertools.product((-1, 0, 1), repeat=len(cells))), dtype=np.int64)
    if not periodic or np.all(cells >= 3):
        first = np.array([row[np.flatnonzero(row)[0]] if row.any() else 1 for row in full])
        return full[first > 0], True
    per_axis = [tuple(sorted({s % int(c) for s in (-1, 0, 1)})) if c < 3 else (-1, 0, 1)
                for c in cells]
    return np.array(list(itertools.product(*per_axis)), dtype=np.int64), False


def neighbour_pairs(x, radius, box=None):
    """Pairs i < j of each instance of x (..., n, d) (d = 2, 3) with |x_j - x_i| < radius:
    (i, j, sep), i and j flat indices into x.reshape(-1, d), sep = x_j - x_i (m, d), the
    minimum image when `box` (d,) gives periodic lengths. radius = inf: every pair."""
    x = np.asarray(x, float)
    radius = float(radius)
    if not radius > 0:
        raise ValueError(f"radius must be > 0, got {radius}")
    if math.isinf(radius):
        if box is not None:
            raise ValueError("a periodic box needs a finite radius (box >= 2 radius)")
        return all_pairs(x)
    n, d = x.shape[-2], x.shape[-1]
    flat = x.reshape(-1, d)
    batch = flat.shape[0] // max(n, 1)
    cells, side, origin, binned = _grid(flat, radius, box)
    coords = np.minimum(np.floor((binned - origin) / side).astype(np.int64), cells - 1)
    strides = np.cumprod(np.concatenate([[1], cells[:-1]]))
    per_instance = int(np.prod(cells))
    instance = np.repeat(np.arange(batch, dtype=np.int64), n) * per_instance
    cell = coords @ strides + instance
    order = np.argsort(cell, kind="stable")
    counts = np.bincount(cell, minlength=batch * per_instance)
    starts = np.cumsum(counts) - counts
    coords_s, instance_s, pos_s = coords[order], instance[order], binned[order]
    offsets, half = _offsets(cells, box is not None)
    found = [_pairs_at_offset(off, half, coords_s, instance_s, pos_s, cells, strides, counts,
                              starts, order, radius, box)
             for off in offsets]  # 5 or 14 (half shell), at most 9 or 27 vectorised passes
    i = np.concatenate([f[0] for f in found])
    j = np.concatenate([f[1] for f in found])
    sep = np.concatenate([f[2] for f in found]).reshape(-1, d)
    return i, j, sep


def _pairs_at_offset(offset, half, coords, instance, pos, cells, strides, counts, starts,
                     order, radius, box):
    """The pairs between every (sorted) particle p and each particle q of the cell at `offset`
    from its own: in a half shell, every candidate of another cell and q > p in its own cell
    (each pair of cells visited once); in a full shell, those with i < j (original indices)."""
    other = coords + offset
    if box is not None:
        other %= cells
        valid = None
    else:
        valid = np.all((other >= 0) & (other < cells), axis=1)
    cell = other @ strides + instance
    if valid is not None:
        cell = np.where(valid, cell, 0)
    count = counts[cell] if valid is None else np.where(valid, counts[cell], 0)
    total = int(count.sum())
    p = np.repeat(np.arange(len(coords)), count)
    run_start = np.cumsum(count) - count  # where each particle's candidates begin
    q = np.repeat(starts[cell] - run_start, count) + np.arange(total)
    if not half:
        keep = order[p] < order[q]
    elif not offset.any():
        keep = p < q
    else:
        keep = None
    if keep is not None:
        p, q = p[keep], q[keep]
    sep = pos[q] - pos[p]
    if box is not None:
        lengths = np.asarray(box, float)
        sep -= lengths * np.round(sep / lengths)
    close = np.einsum("ij,ij->i", sep, sep) < radius * radius
    i, j, sep = order[p[close]], order[q[close]], sep[close]
    swap = i > j  # return i < j and sep = x_j - x_i
    sep[swap] *= -1.0
    return np.where(swap, j, i), np.where(swap, i, j), sep
