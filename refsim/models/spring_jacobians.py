"""Spring-network Jacobians as scipy.sparse matrices (issue 16's first step: Baraff & Witkin's
implicit step on cloth needs df/dx and df/dv of 10^4..10^5 nodes, which the dense (3n x 3n)
`SpringSet.jacobians` cannot hold).

For a spring s between bodies i and j (or i and a fixed anchor), d = x_i - x_j, u = d / |d|,
the 3x3 blocks are (Baraff & Witkin 1998, sec. 4.2; the same formulas as SpringSet.jacobians):
    K_s = -k ((1 - L0/|d|) I + (L0/|d|) u u^T)         (df_i/dx_i)
    D_s = -c u u^T                                     (df_i/dv_i; the x-derivative of the
                                                        damping direction left out, as there)
and each enters (i, i) and, with a second body, (j, j) with +, (i, j) and (j, i) with -. All
blocks are scattered in one COO construction (duplicates summed by scipy), no Python loop over
springs. Returns CSR matrices of shape (3n, 3n) for a single state x, v of shape (n, 3).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def spring_blocks(springs, x, v):
    """(K, D): the per-spring 3x3 blocks, each of shape (m, 3, 3)."""
    d, _ = springs._ends(x, v)
    length, unit = springs._axis(d)
    uu = unit[:, :, None] * unit[:, None, :]
    ratio = np.divide(springs.rest[:, None], length, out=np.zeros_like(length),
                      where=length > 0)[:, :, None]
    kx = -springs.stiffness[:, None, None] * ((1.0 - ratio) * np.eye(3) + ratio * uu)
    kv = -springs.damping[:, None, None] * uu
    return kx, kv


def _scatter(blocks, rows_body, cols_body, n):
    """COO triplets of 3x3 blocks placed at body rows/cols (block index arrays)."""
    r = 3 * rows_body[:, None, None] + np.arange(3)[None, :, None]
    c = 3 * cols_body[:, None, None] + np.arange(3)[None, None, :]
    r, c = np.broadcast_to(r, blocks.shape), np.broadcast_to(c, blocks.shape)
    return r.reshape(-1), c.reshape(-1), blocks.reshape(-1)


def assemble(springs, blocks, n: int) -> sp.csr_matrix:
    """The (3n, 3n) matrix of the spring blocks: +block on (i,i), (j,j); -block on (i,j),
    (j,i) for springs with a second body."""
    pair = springs.other >= 0
    i, j = springs.body, springs.other[pair]
    parts = [_scatter(blocks, i, i, n)]
    if pair.any():
        bp = blocks[pair]
        ip = springs.body[pair]
        parts += [_scatter(bp, j, j, n), _scatter(-bp, ip, j, n), _scatter(-bp, j, ip, n)]
    rows = np.concatenate([p[0] for p in parts])
    cols = np.concatenate([p[1] for p in parts])
    vals = np.concatenate([p[2] for p in parts])
    return sp.csr_matrix((vals, (rows, cols)), shape=(3 * n, 3 * n))


def sparse_jacobians(springs, x, v):
    """(df/dx, df/dv) as CSR (3n x 3n) for one state x, v of shape (n, 3) (a one-off: a
    stepper calling it every step keeps a `JacobianAssembler`)."""
    x, v = np.asarray(x, float), np.asarray(v, float)
    kx, kv = spring_blocks(springs, x, v)
    n = x.shape[0]
    return assemble(springs, kx, n), assemble(springs, kv, n)


class JacobianAssembler:
    """The network's sparsity pattern, found once: every step only sums the blocks' 9 m (or
    36 m) values into the CSR data array (np.bincount over the precomputed slot of each
    triplet), instead of scipy's COO -> CSR sort with duplicates each time."""

    def __init__(self, springs, n: int):
        self.springs, self.n = springs, int(n)
        ones = np.ones((len(springs.body), 3, 3))
        rows, cols, _ = self._triplets(ones)
        keys = rows.astype(np.int64) * (3 * n) + cols
        unique, self.slot = np.unique(keys, return_inverse=True)
        self.indices = (unique % (3 * n)).astype(np.int32)
        counts = np.bincount((unique // (3 * n)).astype(np.int64), minlength=3 * n)
        self.indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
        self.nnz = len(unique)

    def _triplets(self, blocks):
        springs = self.springs
        pair = springs.other >= 0
        i, j = springs.body, springs.other[pair]
        parts = [_scatter(blocks, i, i, self.n)]
        if pair.any():
            bp, ip = blocks[pair], springs.body[pair]
            parts += [_scatter(bp, j, j, self.n), _scatter(-bp, ip, j, self.n),
                      _scatter(-bp, j, ip, self.n)]
        return tuple(np.concatenate([p[k] for p in parts]) for k in range(3))

    def _values(self, blocks):
        """The triplet values in `_triplets` order (the blocks, then -blocks of pairs)."""
        pair = self.springs.other >= 0
        if not pair.any():
            return blocks.reshape(-1)
        bp = blocks[pair].reshape(-1)
        return np.concatenate([blocks.reshape(-1), bp, -bp, -bp])

    def matrix(self, blocks) -> sp.csr_matrix:
        data = np.bincount(self.slot, weights=self._values(blocks), minlength=self.nnz)
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(3 * self.n,) * 2)

    def __call__(self, x, v):
        kx, kv = spring_blocks(self.springs, np.asarray(x, float), np.asarray(v, float))
        return self.matrix(kx), self.matrix(kv)
