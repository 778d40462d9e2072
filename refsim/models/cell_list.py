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
from typing import NamedTuple

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
    found = pair_search(x, radius, box)
    i, j = found.order[found.first], found.order[found.second]
    sep = np.stack(found.sep, axis=-1) if found.sep else np.empty((0, np.shape(x)[-1]))
    swap = i > j  # return i < j and sep = x_j - x_i
    sep[swap] *= -1.0
    return np.where(swap, j, i), np.where(swap, i, j), sep


class PairSearch(NamedTuple):
    """The pairs within the radius in the search's own (cell-sorted) numbering: particle
    order[first[k]] and order[second[k]] of x.reshape(-1, d) (either may be the larger), sep
    a tuple of d arrays (m,), the components of x_second - x_first (minimum image)."""
    first: np.ndarray
    second: np.ndarray
    sep: tuple
    order: np.ndarray


def pair_search(x, radius, box=None) -> PairSearch:
    """The pairs of `neighbour_pairs` without putting them in index order (what a force sum
    needs: scatter into the sorted numbering, then x[order] = sorted values)."""
    x = np.asarray(x, float)
    radius = float(radius)
    if not radius > 0:
        raise ValueError(f"radius must be > 0, got {radius}")
    if math.isinf(radius):
        if box is not None:
            raise ValueError("a periodic box needs a finite radius (box >= 2 radius)")
        i, j, sep = all_pairs(x)
        return PairSearch(i, j, tuple(sep.T), np.arange(int(np.prod(x.shape[:-1]))))
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
    offsets, half = _offsets(cells, box is not None)
    if half:
        sorted_grid = _SortedGrid(coords[order], instance[order], cell[order],
                                  tuple(np.ascontiguousarray(binned[order].T)), cells,
                                  strides, counts, starts, box)
        found = [sorted_grid.pass_at(offset, radius) for offset in offsets]  # 5 or 14
    else:  # a periodic axis of < 3 cells: the full shell, 9 or 27 passes
        found = [_pairs_at_offset(off, coords[order], instance[order], binned[order], cells,
                                  strides, counts, starts, order, radius, box)
                 for off in offsets]
    return PairSearch(np.concatenate([f[0] for f in found]),
                      np.concatenate([f[1] for f in found]),
                      tuple(np.concatenate([f[2][k] for f in found]) for k in range(d)), order)


class _SortedGrid:
    """Particles sorted by cell (cell coordinates and positions as contiguous per-axis arrays),
    for the half shell passes: each pass pairs every particle p with the particles q of ONE
    cell, the one at `offset` from p's own (in its own cell only q > p), all particles at once."""

    def __init__(self, coords, instance, cell, components, cells, strides, counts, starts,
                 box):
        self.axes = tuple(np.ascontiguousarray(coords.T))  # d arrays (n,): cell coordinates
        self.cell, self.components = cell, components
        self.cells, self.strides = cells, strides
        self.counts, self.starts = counts, starts
        self.box = None if box is None else np.asarray(box, float)
        self.index = np.arange(len(cell))

    def _partners(self, offset):
        """(first q (n,), count (n,), wraps): each particle's partner run, and per wrapped
        axis (k, the particles whose neighbour cell lies across the periodic boundary, the
        image shift offset_k L_k)."""
        if not offset.any():  # own cell: q from p + 1 to the cell's end
            end = self.starts[self.cell] + self.counts[self.cell]
            return self.index + 1, end - self.index - 1, []
        cell = self.cell + int(offset @ self.strides)
        valid, wraps = None, []
        for k in np.flatnonzero(offset):  # the axes this offset moves along (1 to 3)
            step = int(offset[k])
            moved = self.axes[k] + step
            across = moved >= self.cells[k] if step > 0 else moved < 0
            if self.box is None:
                valid = ~across if valid is None else valid & ~across
                continue
            wrapped = np.flatnonzero(across)  # the neighbour is cell 0 or cells - 1: its image
            cell[wrapped] -= step * int(self.cells[k] * self.strides[k])
            wraps.append((k, wrapped, step * float(self.box[k])))
        if valid is None:
            return self.starts[cell], self.counts[cell], wraps
        cell = np.where(valid, cell, 0)
        return self.starts[cell], np.where(valid, self.counts[cell], 0), wraps

    def pass_at(self, offset, radius):
        """(p, q, sep components) of the pairs within the radius at this offset. The
        separation is (x_q - x_p) + wrap L: the minimum image within the radius (>= 3 cells
        per periodic axis), bit for bit what x_q - x_p - L round((x_q - x_p) / L) gives."""
        first, count, wraps = self._partners(offset)
        run_start = np.cumsum(count) - count  # where each particle's candidates begin
        p = np.repeat(self.index, count)
        q = _runs(first, count, run_start)
        seps = [comp[q] - comp[p] for comp in self.components]  # the 2 or 3 axes
        for k, wrapped, shift in wraps:
            seps[k][_runs(run_start[wrapped], count[wrapped])] += shift
        close = np.flatnonzero(squared_norm(seps) < radius * radius)
        return p[close], q[close], [sep[close] for sep in seps]


def _runs(first, count, run_start=None):
    """The concatenated ranges first[k], ..., first[k] + count[k] - 1 (no loop)."""
    if run_start is None:
        run_start = np.cumsum(count) - count
    return np.repeat(first - run_start, count) + np.arange(int(run_start[-1] + count[-1])
                                                            if len(count) else 0)


def squared_norm(components):
    """|sep|^2 in numpy's einsum order on x86-64: d_x^2 + d_y^2, (d_x^2 + d_z^2) + d_y^2 (on aarch64
    einsum fuses multiply-adds: an ulp or two apart)."""
    out = components[0] * components[0]
    last = components[-1] * components[-1]
    out += last  # x + y in 2D, x + z in 3D
    if len(components) == 3:
        np.multiply(components[1], components[1], out=last)
        out += last
    return out


def _pairs_at_offset(offset, coords, instance, pos, cells, strides, counts, starts,
                     order, radius, box):
    """The full shell's pass (a periodic axis of < 3 cells): every (sorted) particle p and
    each particle q of the cell at `offset` from its own, kept when order[p] < order[q] (each
    pair is met from both sides), the separation the minimum image x_q - x_p - L round(.)."""
    other = (coords + offset) % cells
    cell = other @ strides + instance
    count = counts[cell]
    total = int(count.sum())
    p = np.repeat(np.arange(len(coords)), count)
    run_start = np.cumsum(count) - count  # where each particle's candidates begin
    q = np.repeat(starts[cell] - run_start, count) + np.arange(total)
    keep = order[p] < order[q]
    p, q = p[keep], q[keep]
    sep = pos[q] - pos[p]
    lengths = np.asarray(box, float)
    sep -= lengths * np.round(sep / lengths)
    close = np.einsum("ij,ij->i", sep, sep) < radius * radius
    return p[close], q[close], list(sep[close].T)
