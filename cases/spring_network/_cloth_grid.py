"""The square cloth grid of the cloth cases: node positions, structural and shear edges, the
triangulation's interior dihedral quads, pinned nodes (all vectorised over the grid).

Node (row r, column c) of an n x n grid is index r n + c; row 0 is the top edge. The cloth
lies in the x-z plane turned by `tilt` about the x axis (the top edge): node (r, c) at
x = c l, y = r l sin(tilt), z = -r l cos(tilt), l = side / (n - 1).
Triangulation: every cell (r, c) is cut along its diagonal (r, c) - (r + 1, c + 1) into the
triangles A = (r, c), (r + 1, c), (r + 1, c + 1) and B = (r, c), (r + 1, c + 1), (r, c + 1).
"""
from __future__ import annotations

import numpy as np


def node_index(n: int) -> np.ndarray:
    return np.arange(n * n).reshape(n, n)


def grid_positions(n: int, side: float, tilt: float = 0.0) -> np.ndarray:
    """(n^2, 3) positions, row-major from the top-left corner (see module doc)."""
    spacing = side / (n - 1)
    rows, cols = np.divmod(np.arange(n * n), n)
    return np.stack([cols * spacing, rows * spacing * np.sin(tilt),
                     -rows * spacing * np.cos(tilt)], axis=1)


def structural_edges(n: int) -> np.ndarray:
    """(2 n (n - 1), 2): the grid's horizontal then vertical neighbour pairs."""
    idx = node_index(n)
    horizontal = np.stack([idx[:, :-1].ravel(), idx[:, 1:].ravel()], axis=1)
    vertical = np.stack([idx[:-1, :].ravel(), idx[1:, :].ravel()], axis=1)
    return np.concatenate([horizontal, vertical])


def shear_edges(n: int) -> np.ndarray:
    """(2 (n - 1)^2, 2): both diagonals of every cell."""
    idx = node_index(n)
    down_right = np.stack([idx[:-1, :-1].ravel(), idx[1:, 1:].ravel()], axis=1)
    down_left = np.stack([idx[:-1, 1:].ravel(), idx[1:, :-1].ravel()], axis=1)
    return np.concatenate([down_right, down_left])


def dihedral_quads(n: int) -> np.ndarray:
    """(l, 4) quads (a, b, c, d): triangles (a, b, c) and (d, c, b) sharing the edge b -> c,
    wound alike (their normals agree on the flat grid: rest angle 0), one per interior edge of
    the triangulation: every cell diagonal, every interior horizontal edge and every interior
    vertical edge; l = (n - 1)^2 + 2 (n - 1)(n - 2)."""
    idx = node_index(n)
    tl, tr, bl, br = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    # the diagonal tl -> br inside each cell: A's third node bl, B's third node tr
    diagonal = np.stack([bl, br, tl, tr], axis=-1).reshape(-1, 4)
    # horizontal edge (r, c) -> (r, c + 1), r interior: B of cell (r - 1, c) above (its third
    # node (r - 1, c)), A of cell (r, c) below (third node (r + 1, c + 1))
    top, bottom = idx[1:-1, :-1], idx[1:-1, 1:]
    horizontal = np.stack([idx[:-2, :-1], top, bottom, idx[2:, 1:]], axis=-1).reshape(-1, 4)
    # vertical edge (r, c) -> (r + 1, c), c interior: A of cell (r, c) right (third node
    # (r + 1, c + 1)), B of cell (r, c - 1) left (third node (r, c - 1))
    upper, lower = idx[:-1, 1:-1], idx[1:, 1:-1]
    vertical = np.stack([idx[1:, 2:], upper, lower, idx[:-1, :-2]], axis=-1).reshape(-1, 4)
    return np.concatenate([diagonal, horizontal, vertical])


def pinned_nodes(n: int, pin: str) -> np.ndarray:
    """"corners": the two top corners; "top_row": the whole top row."""
    if pin == "corners":
        return np.array([0, n - 1])
    if pin == "top_row":
        return np.arange(n)
    raise ValueError(f"pin must be 'corners' or 'top_row', got {pin!r}")
