"""Bending terms of a `SpringNetwork` (slide 002: bending springs, Provot 95, as angle springs):
hinges over node triples and dihedrals over node quads, each with energy
1/2 k (theta - theta0)^2 (angle conventions: refsim.scene.networks).

Every term offers `energy(x)`, `forces(x)` (= -grad energy, batch axes allowed) and
`jacobian(x)` (the force Jacobian -Hessian, a symmetric CSR (3n, 3n) over ALL n nodes; the
sparsity pattern is found once, `BlockPattern`). x holds all node positions, (..., n, 3).

Hinge (a, b, c), e1 = x_b - x_a, e2 = x_c - x_b, turning angle theta = arccos(c),
c = e1.e2 / (|e1| |e2|). The energy is F(c) = 1/2 k (arccos c - theta0)^2, so
    grad E = F'(c) grad c,   Hess E = F''(c) grad c grad c^T + F'(c) Hess c,
    F'(c) = -k (theta - theta0) / sin theta,
    F''(c) = k (sin theta - (theta - theta0) cos theta) / sin^3 theta,
with grad c and Hess c the (smooth, for nonzero lengths) derivatives of the cosine
(derived in `_cosine_derivatives`). With theta0 = 0 the energy 1/2 k arccos(c)^2 is analytic
at c = 1 (a straight hinge): F' -> -k and F'' -> k / 3 (evaluated through theta / sin theta =
1 / sinc and a series for (sin theta - theta cos theta) / theta^3, no cancellation), so forces
(0 at theta = 0) and Jacobians are continuous through the straight configuration.
With theta0 != 0 the unsigned turning angle has a cone at theta = 0 (and every theta0 != pi
one at theta = pi): the energy is not differentiable there. Nothing is raised; at exactly
sin theta = 0 the theta0 parts of F' and F'' are taken as 0 (force 0, the cone's tip, and a
finite Jacobian that is not the (unbounded) curvature there).

Dihedral (a, b, c, d), edge E = c - b, wing normals n1 = (b - a) x (c - a),
n2 = (c - d) x (b - d): the gradient of the signed angle is Bridson, Marino & Fedkiw 2003
("Simulation of clothing with folds and wrinkles", SCA, sec. 4.1), in this module's sign:
    dtheta/da = -|E| n1 / |n1|^2,   dtheta/dd = -|E| n2 / |n2|^2,
    dtheta/db = ((a - c).E / |E|^2) dtheta/da + ((d - c).E / |E|^2) dtheta/dd,
    dtheta/dc = -((a - b).E / |E|^2) dtheta/da - ((d - b).E / |E|^2) dtheta/dd,
a rational function of x and |E| = sqrt(E.E) (analytic). Its Hessian is taken by complex-step
differentiation of that gradient (Squire & Trapp 1998: Im g(x + i h e_j) / h = dg/dx_j with
error O(h^2 |g'''|), zero in float64 at h = 1e-30 m, and no subtraction: exact to round-off);
Hess E = k (grad theta grad theta^T + (theta - theta0) Hess theta). theta is in [-pi, pi]:
the energy jumps where the angle wraps through +-pi (a wing folded through the other); degenerate
wings (|n1| or |n2| = 0) are not evaluated here (the scene refuses them initially).
"""
from __future__ import annotations

from math import factorial

import numpy as np
import scipy.sparse as sp

from ..scene.networks import dihedral_angles

# (sin t - t cos t) / t^3 = sum_{n>=1} (-1)^(n+1) 2n t^(2n-2) / (2n+1)! (the Taylor series of
# sin and t cos t subtracted term by term); 12 terms: the first left out, 24 / 25! < 1e-23,
# is below round-off for |t| <= 1, where it is used.
_SERIES = np.array([(-1) ** (n + 1) * 2 * n / factorial(2 * n + 1) for n in range(1, 13)])
COMPLEX_STEP = 1e-30  # m; see the module doc


def _dot(a, b):
    return np.einsum("...i,...i->...", a, b)


def _cross(a, b):
    """a x b over the last axis (np.cross's axis handling costs more than the product on
    the small arrays of a rope)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _sin_minus_t_cos_over_t3(t):
    """(sin t - t cos t) / t^3, 1/3 at t = 0: the series for |t| <= 1, directly beyond."""
    t2 = t * t
    series = np.polyval(_SERIES[::-1], t2)
    small = np.abs(t) <= 1
    direct = (np.sin(t) - t * np.cos(t)) / np.where(small, 1.0, t) ** 3
    return np.where(small, series, direct)


def _safe_div(num, den):
    return np.divide(num, den, out=np.zeros(np.broadcast(num, den).shape), where=den != 0)


def energy_derivatives(theta, theta0, k):
    """(F'(c), F''(c)) of F(c) = 1/2 k (arccos c - theta0)^2 at c = cos theta (module doc)."""
    sin = np.sin(theta)
    sinc = np.sinc(theta / np.pi)
    first = -k * (1.0 / sinc - _safe_div(theta0, sin))
    g = _sin_minus_t_cos_over_t3(theta) / sinc ** 3  # (sin t - t cos t) / sin^3 t
    second = k * (g + _safe_div(theta0 * np.cos(theta), sin ** 3))
    return first, second


class BlockPattern:
    """The CSR pattern of dense (3p x 3p) blocks over node tuples (k, p), found once: a
    Jacobian is then one np.bincount of the block values into the CSR data (as
    refsim.models.spring_jacobians.JacobianAssembler). Also scatters per-tuple node forces
    (..., k, p, 3) onto the n nodes with a precomputed sparse incidence matrix."""

    def __init__(self, nodes: np.ndarray, n: int, free: np.ndarray | None = None):
        """free (n,) bool: the Jacobian's rows and columns are the free nodes' only (blocks
        touching a fixed node lose those rows/columns); None: every node."""
        self.n, (k, p) = int(n), nodes.shape
        index = np.arange(n) if free is None else np.where(free, np.cumsum(free) - 1, -1)
        self.m = self.n if free is None else int(np.count_nonzero(free))
        node_index = index[nodes]
        dofs = (3 * node_index[:, :, None] + np.arange(3)).reshape(k, 3 * p)
        rows = np.broadcast_to(dofs[:, :, None], (k, 3 * p, 3 * p)).reshape(-1)
        cols = np.broadcast_to(dofs[:, None, :], (k, 3 * p, 3 * p)).reshape(-1)
        self.keep = None if free is None else (rows >= 0) & (cols >= 0)
        if self.keep is not None:
            rows, cols = rows[self.keep], cols[self.keep]
        size = 3 * self.m
        keys = rows.astype(np.int64) * size + cols
        unique, self.slot = np.unique(keys, return_inverse=True)
        self.indices = (unique % size).astype(np.int32)
        counts = np.bincount((unique // size).astype(np.int64), minlength=size)
        self.indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
        self.nnz = len(unique)
        self.incidence = sp.csr_matrix((np.ones(k * p), (nodes.reshape(-1), np.arange(k * p))),
                                       shape=(n, k * p))

    def matrix(self, blocks: np.ndarray) -> sp.csr_matrix:
        """blocks (k, 3p, 3p) summed into the (3m, 3m) CSR matrix (m: the kept nodes)."""
        values = blocks.reshape(-1) if self.keep is None else blocks.reshape(-1)[self.keep]
        data = np.bincount(self.slot, weights=values, minlength=self.nnz)
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(3 * self.m,) * 2)

    def scatter(self, per_tuple: np.ndarray) -> np.ndarray:
        """per-tuple node vectors (..., k, p, 3) summed onto nodes: (..., n, 3)."""
        batch = per_tuple.shape[:-3]
        if not batch:
            return self.incidence @ per_tuple.reshape(-1, 3)
        flat = np.moveaxis(per_tuple.reshape(batch + (-1, 3)), -2, 0)
        out = self.incidence @ flat.reshape(flat.shape[0], -1)
        return np.moveaxis(out.reshape((self.n,) + batch + (3,)), 0, -2)


def _cosine_derivatives(e1, e2):
    """(grad c (k, 2, 3), Hess c (k, 2, 2, 3, 3)) of c = e1.e2 / (|e1| |e2|) in (e1, e2);
    with u_i = e_i / |e_i|, L_i = |e_i|:
      dc/de1 = (u2 - c u1) / L1,  d2c/de1^2 = -(u1 u2^T + u2 u1^T - 3c u1 u1^T + c I) / L1^2,
      d2c/de1 de2 = (I - u1 u1^T - u2 u2^T + c u1 u2^T) / (L1 L2), and 1 <-> 2."""
    l1, l2 = np.sqrt(_dot(e1, e1)), np.sqrt(_dot(e2, e2))
    u1, u2 = e1 / l1[:, None], e2 / l2[:, None]
    c = _dot(u1, u2)
    grad = np.stack([(u2 - c[:, None] * u1) / l1[:, None], (u1 - c[:, None] * u2) / l2[:, None]],
                    axis=1)
    eye = np.eye(3)

    def outer(a, b):
        return a[:, :, None] * b[:, None, :]

    def same(ua, ub, la):
        sym = outer(ua, ub) + outer(ub, ua) - 3 * c[:, None, None] * outer(ua, ua)
        return -(sym + c[:, None, None] * eye) / (la * la)[:, None, None]

    cross = (eye - outer(u1, u1) - outer(u2, u2) + c[:, None, None] * outer(u1, u2)) \
        / (l1 * l2)[:, None, None]
    hess = np.stack([np.stack([same(u1, u2, l1), cross], 1),
                     np.stack([np.swapaxes(cross, 1, 2), same(u2, u1, l2)], 1)], 1)
    return grad, hess


# node a = -e1, b = e1 - e2, c = e2: d/dx_node = sum_i EDGE_OF_NODE[node, i] d/de_i
EDGE_OF_NODE = np.array([[-1.0, 0.0], [1.0, -1.0], [0.0, 1.0]])


def _node_blocks(h_edges):
    """(k, 9, 9) node Hessian sum_ij C_pi C_qj H_ij (C = EDGE_OF_NODE) of the edge Hessian
    blocks H_ij (k, 2, 2, 3, 3), written out (cheaper than a contraction over 2 x 2)."""
    h11, h12, h21, h22 = h_edges[:, 0, 0], h_edges[:, 0, 1], h_edges[:, 1, 0], h_edges[:, 1, 1]
    rows = [[h11, h12 - h11, -h12],
            [h21 - h11, h11 - h12 - h21 + h22, h12 - h22],
            [-h21, h21 - h22, h22]]
    blocks = np.stack([np.stack(row, axis=1) for row in rows], axis=1)  # (k, p, q, 3, 3)
    return blocks.transpose(0, 1, 3, 2, 4).reshape(-1, 9, 9)


class _AngleSprings:
    """Springs 1/2 k (theta - theta0)^2 on an angle of node tuples (k, p): `angles(x)` is the
    subclass's; k and theta0 per tuple (scalars broadcast); n nodes in all."""

    def __init__(self, nodes, stiffness, rest_angle, n: int):
        self.nodes = np.asarray(nodes, int)
        self.k = np.broadcast_to(np.asarray(stiffness, float), len(self.nodes))
        self.theta0 = np.broadcast_to(np.asarray(rest_angle, float), len(self.nodes))
        self.n = int(n)
        self._patterns = {}  # free-node mask (bytes) or None -> BlockPattern

    def energy(self, x) -> float:
        return float(0.5 * np.sum(self.k * (self.angles(x) - self.theta0) ** 2))

    def _pattern_once(self, free=None) -> BlockPattern:
        return _cached_pattern(self, free)


class HingeSet(_AngleSprings):
    """Hinge springs 1/2 k (theta - theta0)^2 on the turning angle at b of (a, b, c)."""

    def _edges(self, x):
        a, b, c = (x[..., self.nodes[:, i], :] for i in range(3))
        return b - a, c - b

    def angles(self, x) -> np.ndarray:
        e1, e2 = self._edges(x)
        return np.arctan2(np.linalg.norm(np.cross(e1, e2), axis=-1), _dot(e1, e2))

    def forces(self, x) -> np.ndarray:
        """-grad E on every node, (..., n, 3): -F'(c) grad c mapped onto a, b, c."""
        e1, e2 = self._edges(np.asarray(x, float))
        l1, l2 = np.sqrt(_dot(e1, e1))[..., None], np.sqrt(_dot(e2, e2))[..., None]
        u1, u2 = e1 / l1, e2 / l2
        c = _dot(u1, u2)
        sin = np.sqrt(_dot(*(2 * (_cross(u1, u2),))))
        theta = np.arctan2(sin, c)
        first = -self.k / np.sinc(theta / np.pi)  # F'(c) (module doc), theta0 = 0 part
        if self.theta0.any():
            first = first + self.k * _safe_div(self.theta0, sin)
        c, first = c[..., None], first[..., None]
        g1 = -first * (u2 - c * u1) / l1  # the force conjugate to e1 (on b, minus on a)
        g2 = -first * (u1 - c * u2) / l2
        return self._pattern_once().scatter(np.stack([-g1, g1 - g2, g2], axis=-2))

    def jacobian(self, x, free=None) -> sp.csr_matrix:
        """d forces / dx = -Hess E, (3n, 3n) CSR, for one state x (n, 3); with `free` (n,)
        bool, the free nodes' rows and columns only."""
        e1, e2 = self._edges(np.asarray(x, float))
        grad, hess = _cosine_derivatives(e1, e2)
        theta = np.arctan2(np.linalg.norm(np.cross(e1, e2), axis=-1), _dot(e1, e2))
        first, second = energy_derivatives(theta, self.theta0, self.k)
        h_edges = second[:, None, None, None, None] * (grad[:, :, None, :, None]
                                                       * grad[:, None, :, None, :]) \
            + first[:, None, None, None, None] * hess
        return self._pattern_once(free).matrix(-_node_blocks(h_edges))


def dihedral_gradient(a, b, c, d):
    """dtheta/d(a, b, c, d), (..., 4, 3) (Bridson et al. 2003; module doc); complex-safe."""
    edge = c - b
    edge_sq = _dot(edge, edge)
    edge_len = np.sqrt(edge_sq)[..., None]
    n1, n2 = np.cross(b - a, c - a), np.cross(c - d, b - d)
    ga = -edge_len * n1 / _dot(n1, n1)[..., None]
    gd = -edge_len * n2 / _dot(n2, n2)[..., None]

    def along(p, q):
        return (_dot(p - q, edge) / edge_sq)[..., None]

    gb = along(a, c) * ga + along(d, c) * gd
    gc = -along(a, b) * ga - along(d, b) * gd
    return np.stack([ga, gb, gc, gd], axis=-2)


class DihedralSet(_AngleSprings):
    """Dihedral springs 1/2 k (theta - theta0)^2 on the signed angle about b -> c of (a,b,c,d)."""

    CHUNK = 4096  # dihedrals per complex-step batch (bounds the (chunk, 12, 4, 3) temporaries)

    def _corners(self, x):
        return tuple(x[..., self.nodes[:, i], :] for i in range(4))

    def angles(self, x) -> np.ndarray:
        x = np.asarray(x, float)
        if x.ndim == 2:
            return dihedral_angles(x, self.nodes)
        a, b, c, d = self._corners(x)
        n1, n2 = np.cross(b - a, c - a), np.cross(c - d, b - d)
        unit = (c - b) / np.linalg.norm(c - b, axis=-1)[..., None]
        return np.arctan2(_dot(np.cross(n1, n2), unit), _dot(n1, n2))

    def forces(self, x) -> np.ndarray:
        """-k (theta - theta0) grad theta on every node, (..., n, 3)."""
        x = np.asarray(x, float)
        torque = -self.k * (self.angles(x) - self.theta0)
        per_node = torque[..., None, None] * dihedral_gradient(*self._corners(x))
        return self._pattern_once().scatter(per_node)

    def _hessian_blocks(self, x, rows):
        """Hess theta (r, 12, 12) of the dihedrals `rows` by complex step; grad theta (r, 12)."""
        corners = np.stack([x[self.nodes[rows, i]] for i in range(4)], axis=1)  # (r, 4, 3)
        grad = dihedral_gradient(*(corners[:, i] for i in range(4))).reshape(-1, 12)
        step = (1j * COMPLEX_STEP * np.eye(12)).reshape(12, 4, 3)
        probed = corners[:, None] + step[None]  # (r, 12, 4, 3)
        g = dihedral_gradient(*(probed[:, :, i] for i in range(4))).reshape(-1, 12, 12)
        hess = g.imag / COMPLEX_STEP
        return grad, 0.5 * (hess + np.swapaxes(hess, 1, 2))

    def jacobian(self, x, free=None) -> sp.csr_matrix:
        """d forces / dx = -k (grad theta grad theta^T + (theta - theta0) Hess theta); with
        `free` (n,) bool, the free nodes' rows and columns only."""
        x = np.asarray(x, float)
        offset = self.angles(x) - self.theta0
        blocks = np.empty((len(self.nodes), 12, 12))
        for start in range(0, len(self.nodes), self.CHUNK):  # memory chunks, vectorised inside
            rows = np.arange(start, min(start + self.CHUNK, len(self.nodes)))
            grad, hess = self._hessian_blocks(x, rows)
            blocks[rows] = -self.k[rows, None, None] * (
                grad[:, :, None] * grad[:, None, :] + offset[rows, None, None] * hess)
        return self._pattern_once(free).matrix(blocks)


def _cached_pattern(term, free) -> BlockPattern:
    """The term's pattern for a free-node mask (None: all nodes), found once per mask."""
    key = None if free is None else np.asarray(free, bool).tobytes()
    if key not in term._patterns:
        term._patterns[key] = BlockPattern(term.nodes, term.n, free)
    return term._patterns[key]


def bending_terms(net) -> list:
    """The bending terms of a SpringNetwork: a HingeSet if it has hinges, a DihedralSet if it
    has dihedrals (empty list: neither)."""
    n, terms = len(net), []
    if len(net.hinges):
        terms.append(HingeSet(net.hinges, net.hinge_stiffness, net.hinge_rest_angle, n))
    if len(net.dihedrals):
        terms.append(DihedralSet(net.dihedrals, net.dihedral_stiffness,
                                 net.dihedral_rest_angle, n))
    return terms
