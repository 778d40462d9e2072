"""Witkin-Heckbert sampling of an implicit sphere by gradient descent (slide 003;
`refsim.scene.surface_sampling`), vectorised over every pair and any leading batch axes.

With E_ij = alpha exp(-|p_i - p_j|^2 / (2 sigma^2)) (sigma fixed, so E_ij = E_ji) and
E_i = sum_{j != i} (E_ij + E_ji) = 2 sum_{j != i} E_ij (the slide's j = i term, the constant
2 alpha, moves nothing and is left out):

    grad_{p_i} E_i = -(2 / sigma^2) sum_j E_ij (p_i - p_j)
    u_i = -P_i grad_{p_i} E_i,   P_i = I - n_i n_i^T,  n_i = (p_i - c) / |p_i - c|

(the tangential part), and after every step p_i <- c + R (p_i - c) / |p_i - c| (`project`).
The total sum_i E_i = 4 sum_{i<j} E_ij, whose gradient in p_i is twice grad_{p_i} E_i: each
particle descending its own E_i descends the total at half the rate, so the total decreases
monotonically for small h.

N = 4, 6, 12 points end on the regular tetrahedron, octahedron and icosahedron: these are
universally optimal on the sphere (Cohn & Kumar, J. AMS 20 (2007) 99-148), i.e. minimise every
completely monotone potential of the squared distance, the Gaussian included.
"""
from __future__ import annotations

import numpy as np

# N -> (polyhedron, neighbours of each vertex, angle between neighbours from the centre, deg)
POLYHEDRA = {4: ("tetrahedron", 3, float(np.degrees(np.arccos(-1.0 / 3.0)))),
             6: ("octahedron", 4, 90.0),
             12: ("icosahedron", 5, float(np.degrees(np.arccos(1.0 / np.sqrt(5.0)))))}


class SphereSampling:
    """The first-order system of `refsim.integrators.first_order`: velocity(t, p) (the
    tangential descent velocity) and project(p) onto the sphere, on (..., n, 3) arrays."""

    linear = False

    def __init__(self, radius, centre, sigma, alpha):
        self.radius, self.sigma, self.alpha = float(radius), float(sigma), float(alpha)
        self.centre = np.array(centre, float).reshape(3)

    def pair_terms(self, p):
        """(E_ij (..., n, n), p_i - p_j (..., n, n, 3)); E_ii = alpha multiplies a zero."""
        diff = p[..., :, None, :] - p[..., None, :, :]
        dist2 = np.einsum("...k,...k->...", diff, diff)
        return self.alpha * np.exp(dist2 * (-0.5 / self.sigma ** 2)), diff

    def gradient(self, p):
        """(..., n, 3): grad_{p_i} E_i for every i."""
        pair, diff = self.pair_terms(p)
        return (-2.0 / self.sigma ** 2) * np.einsum("...ij,...ijk->...ik", pair, diff)

    def velocity(self, t, p):
        grad = self.gradient(p)
        normal = p - self.centre
        normal = normal / np.linalg.norm(normal, axis=-1, keepdims=True)
        return -(grad - np.einsum("...k,...k->...", grad, normal)[..., None] * normal)

    def project(self, p):
        rel = p - self.centre
        return self.centre + (self.radius / np.linalg.norm(rel, axis=-1, keepdims=True)) * rel

    def energy(self, p):
        """(...,): sum_i E_i = 2 sum_{i != j} E_ij."""
        pair, _ = self.pair_terms(p)
        n = pair.shape[-1]
        return 2.0 * (np.sum(pair, axis=(-2, -1)) - n * self.alpha)


def neighbour_angles(p, centre, count) -> np.ndarray:
    """(..., n, count): the angles (deg) seen from the centre between each point and its
    `count` nearest neighbours, sorted ascending."""
    rel = np.asarray(p, float) - centre
    unit = rel / np.linalg.norm(rel, axis=-1, keepdims=True)
    cosines = np.clip(np.einsum("...ik,...jk->...ij", unit, unit), -1.0, 1.0)
    angles = np.degrees(np.arccos(cosines))
    n = angles.shape[-1]
    angles = angles + np.diag(np.full(n, np.inf))  # a point is not its own neighbour
    return np.sort(angles, axis=-1)[..., :count]


def polyhedron_angle_error(p, centre) -> np.ndarray:
    """(...,): max over points and their nearest neighbours of |angle - the regular
    polyhedron's| (deg), for N = 4, 6, 12 points (POLYHEDRA)."""
    n = np.shape(p)[-2]
    if n not in POLYHEDRA:
        raise ValueError(f"polyhedron_angle_error: N must be one of {sorted(POLYHEDRA)}, got {n}")
    _, count, ideal = POLYHEDRA[n]
    return np.max(np.abs(neighbour_angles(p, centre, count) - ideal), axis=(-2, -1))


def polyhedron_vertices(n: int) -> np.ndarray:
    """(n, 3) unit vertices of the regular tetrahedron (4), octahedron (6), icosahedron (12)."""
    if n == 4:
        vertices = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
    elif n == 6:
        vertices = np.vstack([np.eye(3), -np.eye(3)])
    elif n == 12:
        phi = 0.5 * (1.0 + np.sqrt(5.0))
        a, b = np.meshgrid([-1.0, 1.0], [-phi, phi], indexing="ij")
        a, b, zero = a.ravel(), b.ravel(), np.zeros(4)
        vertices = np.concatenate([np.stack(c, axis=1) for c in
                                   ((zero, a, b), (a, b, zero), (b, zero, a))])
    else:
        raise ValueError(f"polyhedron_vertices: n must be one of {sorted(POLYHEDRA)}, got {n}")
    return vertices / np.linalg.norm(vertices, axis=1, keepdims=True)


def relaxation_rates(system: SphereSampling, points, step=1e-6) -> np.ndarray:
    """Eigenvalues (real parts, ascending) of the descent flow linearised at `points` (n, 3)
    on the sphere, restricted to the tangent space (2n of them; 3 are rigid rotations, ~0).
    The Jacobian by central differences, every column at once (the perturbations are a batch
    axis of the vectorised field): truncation O(step^2), round-off O(eps / step)."""
    points = np.asarray(points, float)
    n = len(points)
    basis = np.eye(3 * n).reshape(3 * n, n, 3)
    columns = system.velocity(0.0, points + step * basis) - system.velocity(0.0, points -
                                                                           step * basis)
    jacobian = columns.reshape(3 * n, 3 * n).T / (2.0 * step)
    normal = (points - system.centre) / system.radius
    helper = np.where(np.abs(normal[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    first = np.cross(normal, helper)
    first /= np.linalg.norm(first, axis=1, keepdims=True)
    second = np.cross(normal, first)
    tangent = np.zeros((n, 2, n, 3))
    tangent[np.arange(n), 0, np.arange(n)] = first
    tangent[np.arange(n), 1, np.arange(n)] = second
    tangent = tangent.reshape(2 * n, 3 * n).T  # orthonormal columns
    return np.sort(np.linalg.eigvals(tangent.T @ jacobian @ tangent).real)
