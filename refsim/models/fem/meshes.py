"""Structured P1 meshes for the finite-element model and its cases, every element positively
oriented: rectangles of right triangles, boxes of tetrahedra (6 per cell, Kuhn's split), and
triangle prisms of tetrahedra. Node arrays are float64 (n, 3); cells int64.
"""
from __future__ import annotations

import itertools

import numpy as np


def grid_nodes(counts, lengths, origin=None):
    """Nodes of a regular grid with counts[k] cells of length lengths[k] / counts[k] along
    axis k (2 or 3 axes), x fastest; returned as (n, 3) with z = 0 in 2D."""
    axes = [np.linspace(0.0, float(length), int(c) + 1) for c, length in zip(counts, lengths)]
    mesh = np.meshgrid(*axes[::-1], indexing="ij")[::-1]  # x fastest in the flat order
    nodes = np.stack([m.reshape(-1) for m in mesh], -1)
    if nodes.shape[1] == 2:
        nodes = np.concatenate([nodes, np.zeros((len(nodes), 1))], 1)
    return nodes + (0.0 if origin is None else np.asarray(origin, float))


def rectangle_triangles(nx, ny, lx=1.0, ly=1.0, origin=None):
    """(nodes (n, 3), triangles (2 nx ny, 3)): an nx x ny grid of cells on [0, lx] x [0, ly]
    (plus origin), each cell split along its diagonal from the lower-left corner into the
    right triangles (p00, p10, p11) and (p00, p11, p01), counter-clockwise. Node (i, j) (i
    along x) is number j (nx + 1) + i."""
    nodes = grid_nodes((nx, ny), (lx, ly), origin)
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="xy")
    p00 = (j * (nx + 1) + i).reshape(-1)
    p10, p01 = p00 + 1, p00 + nx + 1
    p11 = p01 + 1
    tris = np.concatenate([np.stack([p00, p10, p11], 1), np.stack([p00, p11, p01], 1)])
    return nodes, tris


def _orient(nodes, tets):
    """Tetrahedra with two nodes swapped where the signed volume is negative."""
    x0, x1, x2, x3 = (nodes[tets[:, k]] for k in range(4))
    negative = np.einsum("ij,ij->i", x1 - x0, np.cross(x2 - x0, x3 - x0)) < 0
    tets = tets.copy()
    tets[negative, 2], tets[negative, 3] = tets[negative, 3], tets[negative, 2].copy()
    return tets


def box_tetrahedra(nx, ny, nz, lx=1.0, ly=1.0, lz=1.0, origin=None):
    """(nodes, tetrahedra (6 nx ny nz, 4)): each cell split into Kuhn's 6 tetrahedra along its
    main diagonal (one per permutation of the axes: corners 0, e_a, e_a + e_b, (1, 1, 1)); the
    split is the same in every cell, so faces match (a conforming mesh)."""
    nodes = grid_nodes((nx, ny, nz), (lx, ly, lz), origin)
    stride = np.array([1, nx + 1, (nx + 1) * (ny + 1)])
    i, j, k = (a.reshape(-1) for a in np.meshgrid(np.arange(nx), np.arange(ny),
                                                   np.arange(nz), indexing="ij"))
    base = i * stride[0] + j * stride[1] + k * stride[2]
    tets = []
    for perm in itertools.permutations(range(3)):  # 6 local patterns, not a loop over cells
        corner = np.zeros(3, int)
        local = [0]
        for axis in perm:
            corner[axis] = 1
            local.append(int(corner @ stride))
        tets.append(base[:, None] + np.array(local)[None, :])
    return nodes, _orient(nodes, np.concatenate(tets))


def prism_tetrahedra(nodes2d, triangles, thickness):
    """(nodes, tetrahedra): the triangle mesh (nodes z = 0) extruded to z in [0, thickness],
    each prism split into 3 tetrahedra by sorted node number, so that the shared quad faces
    are split the same way from both sides. Node k of the bottom layer is k, of the top
    n + k."""
    nodes2d = np.asarray(nodes2d, float)
    n = len(nodes2d)
    top = nodes2d + np.array([0.0, 0.0, float(thickness)])
    nodes = np.concatenate([nodes2d, top])
    a, b, c = np.sort(triangles, axis=1).T
    tets = np.concatenate([np.stack([a, b, c, a + n], 1), np.stack([b, c, a + n, b + n], 1),
                           np.stack([c, a + n, b + n, c + n], 1)])
    return nodes, _orient(nodes, tets)


def perturb_interior(nodes, amount, seed=0):
    """The nodes with every interior node (not on the bounding box) moved by a uniform random
    offset of up to amount (m) per axis in the mesh's axes (z left alone for a plane mesh):
    an irregular mesh for patch tests. Below a quarter of the cell size the elements keep
    their orientation."""
    nodes = np.array(nodes, float)
    axes = [k for k in range(3) if np.ptp(nodes[:, k]) > 0]
    lo, hi = nodes[:, axes].min(0), nodes[:, axes].max(0)
    inner = np.all((nodes[:, axes] > lo) & (nodes[:, axes] < hi), 1)
    rng = np.random.default_rng(seed)
    offsets = rng.uniform(-amount, amount, (int(inner.sum()), len(axes)))
    nodes[np.ix_(inner, axes)] += offsets
    return nodes
