"""The grid SDF model (refsim.models.collision.sdf): the exact signed distances against
independent checks (a brute-force distance to sampled surfaces, the projection onto the
surface, finite differences), the node sampling's axis order, and the trilinear interpolant:
exact on trilinear data, through the node values, its gradient the interpolant's own."""
import numpy as np
import pytest
from scipy.spatial import cKDTree
from ulp import EPS, assert_ulp

from refsim.models.collision import sdf

SIZES = {"sphere": (1.0,), "box": (0.9, 0.7, 0.5), "torus": (1.0, 0.4)}


def _points(shape, n=400, seed=0, clear=0.15):
    """Random points in [-2, 2]^3 at least `clear` from each shape's singular set (the
    sphere's centre; the box's edges and inner medial surfaces; the torus's core circle and
    axis): there the SDF is smooth."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-2, 2, (20 * n, 3))
    if shape == "sphere":
        ok = np.linalg.norm(x, axis=1) > clear
    elif shape == "torus":
        rho = np.hypot(x[:, 0], x[:, 1])
        ok = (rho > clear) & (np.hypot(rho - 1.0, x[:, 2]) > clear)
    else:
        q = np.sort(np.abs(x) - np.array(SIZES["box"]), axis=1)
        inside = q[:, 2] < 0
        ok = ~inside | (q[:, 2] - q[:, 1] > 2 * clear)  # a unique nearest face
        ok &= np.sum(np.abs(x) > np.array(SIZES["box"]) - clear, axis=1) < 2  # off the edges
    return x[ok][:n]


def _surface(shape, m=400):
    """Points on the surface on a parameter grid of about m x m (spacing <= 2 pi / m)."""
    u = (np.arange(m) + 0.5) / m
    if shape == "sphere":  # latitude-longitude
        th, ph = np.meshgrid(np.pi * u, 2 * np.pi * u, indexing="ij")
        return np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)],
                        -1).reshape(-1, 3)
    if shape == "torus":
        a, b = np.meshgrid(2 * np.pi * u, 2 * np.pi * u, indexing="ij")
        rho = 1.0 + 0.4 * np.cos(b)
        return np.stack([rho * np.cos(a), rho * np.sin(a), 0.4 * np.sin(b)], -1).reshape(-1, 3)
    b = np.array(SIZES["box"])
    faces = []
    for i in range(3):
        j, k = [a for a in range(3) if a != i]
        s, t = np.meshgrid(b[j] * (2 * u - 1), b[k] * (2 * u - 1), indexing="ij")
        for sign in (-1, 1):
            face = np.empty(s.shape + (3,))
            face[..., i], face[..., j], face[..., k] = sign * b[i], s, t
            faces.append(face.reshape(-1, 3))
    return np.concatenate(faces)


@pytest.mark.parametrize("shape", sorted(SIZES))
def test_exact_sdf_is_the_distance_to_the_sampled_surface_with_its_sign(shape):
    """|phi| <= the distance to every surface sample (the true distance is the least over
    the whole surface) and within the samples' spacing of the nearest; negative inside."""
    x = _points(shape, 200)
    phi, _ = sdf.exact(shape, SIZES[shape], x)
    nearest = cKDTree(_surface(shape, 200 if shape == "box" else 300)).query(x)[0]
    # the nearest sample is within half a parameter cell's diagonal of the closest point:
    # spacing <= 2 pi R_max / 300 (torus: 1.4 x 2 pi / 300 = 0.029; the box's 200 a face: 1.8 / 200)
    spacing = 2 * np.pi * 1.4 / 300
    assert np.all(nearest >= np.abs(phi) - 1e-12)  # 1e-12: the samples' own round-off
    assert np.all(nearest <= np.abs(phi) + spacing)
    if shape == "sphere":
        inside = np.linalg.norm(x, axis=1) < 1
    elif shape == "box":
        inside = np.all(np.abs(x) < np.array(SIZES["box"]), axis=1)
    else:
        inside = np.hypot(np.hypot(x[:, 0], x[:, 1]) - 1.0, x[:, 2]) < 0.4
    assert inside.any() and (~inside).any()
    assert np.array_equal(phi < 0, inside)


@pytest.mark.parametrize("shape", sorted(SIZES))
def test_exact_gradient_is_unit_projects_onto_the_surface_and_matches_differences(shape):
    x = _points(shape)
    phi, grad = sdf.exact(shape, SIZES[shape], x)
    # x / |x| and friends: a few roundings of a unit vector
    assert_ulp(np.linalg.norm(grad, axis=1), np.ones(len(x)), 8, "a unit vector, rounded")
    y = x - phi[:, None] * grad  # the closest surface point
    on, _ = sdf.exact(shape, SIZES[shape], y)
    # the surface point's phi is the rounding of |x| + |phi| sized terms
    assert np.abs(on).max() <= 16 * EPS * 4
    step = 1e-6
    fd = np.stack([(sdf.signed_distance(shape, SIZES[shape], *(x + step * e).T)
                    - sdf.signed_distance(shape, SIZES[shape], *(x - step * e).T)) / (2 * step)
                   for e in np.eye(3)], axis=1)
    # central differences: truncation step^2 |phi'''| / 6 (|phi'''| <= 2 / clear^2 = 89) and
    # round-off eps |phi| / step (4e-10): 1e-8 holds both
    assert np.abs(fd - grad).max() <= 1e-8


def test_sampling_puts_x_on_axis_0_and_the_values_are_the_sdf_at_the_nodes():
    lower, h, nodes = np.array([-1.5, -1.2, -0.8]), 0.1, (31, 25, 17)
    for shape, size in SIZES.items():
        values = sdf.sample(shape, size, lower, h, nodes)
        assert values.shape == nodes and values.dtype == np.float64
        idx = np.stack(np.meshgrid(*map(np.arange, nodes), indexing="ij"), -1).reshape(-1, 3)
        points = lower + h * idx
        want = sdf.signed_distance(shape, size, points[:, 0], points[:, 1], points[:, 2])
        # the same formula on the same node coordinates (lower + h i, one rounding each)
        assert np.array_equal(values.reshape(-1), want)
    assert sdf.sample("box", SIZES["box"], lower, h, nodes, np.float32).dtype == np.float32


def _trilinear_field(rng):
    c = rng.normal(size=8)

    def f(p):
        x, y, z = p.T
        return c[0] + c[1] * x + c[2] * y + c[3] * z + c[4] * x * y + c[5] * y * z \
            + c[6] * x * z + c[7] * x * y * z

    def grad(p):
        x, y, z = p.T
        return np.stack([c[1] + c[4] * y + c[6] * z + c[7] * y * z,
                         c[2] + c[4] * x + c[5] * z + c[7] * x * z,
                         c[3] + c[5] * y + c[6] * x + c[7] * x * y], axis=1)
    return f, grad, np.abs(c).sum()


def test_trilinear_interpolation_is_exact_on_trilinear_functions_with_their_gradient():
    """The interpolant of a trilinear polynomial is that polynomial, on a grid of unequal
    node counts (an axis order mistake would not be)."""
    rng = np.random.default_rng(3)
    f, grad, scale = _trilinear_field(rng)
    lower, h, nodes = np.array([-1.0, -0.7, -0.4]), 0.1, (21, 15, 9)
    axes = sdf.node_axes(lower, h, nodes)
    grid = np.stack(np.broadcast_arrays(*axes), -1)
    values = f(grid.reshape(-1, 3)).reshape(nodes)
    p = rng.uniform(lower, lower + h * (np.array(nodes) - 1), (500, 3))
    phi, g = sdf.trilinear(values, lower, h, p)
    # the terms are at most |c| (|x| <= 1): some tens of roundings of that size
    assert_ulp(phi, f(p), 64, "nested blends against the polynomial's terms", scale=scale)
    # differences of node values of size `scale` divided by h
    assert_ulp(g, grad(p), 64, "node differences / h", scale=scale / h)


def test_trilinear_passes_through_the_node_values():
    """At a node inside the grid t = 0 exactly (dyadic lower and h): every blend adds 0 x
    a difference, so the value is the node's, bit for bit; on the upper boundary t = 1 of
    the cell below: c + 1 (c' - c), within an ulp of c'."""
    rng = np.random.default_rng(5)
    lower, h, nodes = np.array([-1.0, -0.5, 0.25]), 0.125, (6, 5, 4)
    values = rng.normal(size=nodes)
    idx = np.stack(np.meshgrid(*map(np.arange, nodes), indexing="ij"), -1).reshape(-1, 3)
    phi, _ = sdf.trilinear(values, lower, h, lower + h * idx)
    inner = np.all(idx < np.array(nodes) - 1, axis=1)
    assert np.array_equal(phi[inner], values.reshape(-1)[inner])
    # c + (c' - c): two roundings of terms of the values' size
    assert_ulp(phi[~inner], values.reshape(-1)[~inner], 4, "c + 1 (c' - c)",
               scale=np.abs(values).max())


def test_gradient_is_the_interpolants_own_derivative():
    """On random node values (no smoothness to hide behind) the gradient equals central
    differences of the interpolant inside each cell (it is linear along each axis there)."""
    rng = np.random.default_rng(7)
    lower, h, nodes = np.array([0.0, 0.0, 0.0]), 0.2, (5, 6, 7)
    values = rng.normal(size=nodes)
    index = rng.integers(0, np.array(nodes) - 1, (300, 3))
    t = rng.uniform(0.1, 0.9, (300, 3))
    p = lower + h * (index + t)
    _, g = sdf.trilinear(values, lower, h, p)
    step = 1e-4 * h  # stays in the cell: t in [0.1, 0.9]
    fd = np.stack([(sdf.trilinear(values, lower, h, p + step * e)[0]
                    - sdf.trilinear(values, lower, h, p - step * e)[0]) / (2 * step)
                   for e in np.eye(3)], axis=1)
    # exact for a function linear along the axis: only the two values' round-off (tens of
    # eps x max|v| each) over 2 step
    assert np.abs(fd - g).max() <= 64 * EPS * np.abs(values).max() / step


@pytest.mark.parametrize("shape", ["sphere", "box"])
def test_interpolant_of_a_convex_sdf_lies_above_it_everywhere(shape):
    """The sphere's and the box's SDFs are convex (a convex set's), and every linear
    interpolation of a convex function lies above it: phi_h >= phi at every point of the grid,
    near the singular set too (where the O(h^2) bound does not hold)."""
    lower, h, nodes = np.full(3, -1.5), 0.1, (31, 31, 31)
    values = sdf.sample(shape, SIZES[shape], lower, h, nodes)
    p = np.random.default_rng(11).uniform(-1.5, 1.5, (5000, 3))
    phi_h, _ = sdf.trilinear(values, lower, h, p)
    phi, _ = sdf.exact(shape, SIZES[shape], p)
    # round-off of blends and exact phi, terms of size <= 3
    assert np.min(phi_h - phi) >= -32 * EPS * 3
