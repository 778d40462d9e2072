"""Grid signed distance fields of analytic shapes against their exact SDFs (issue 28, case 2;
slide 001: depth phi, normal grad phi; trilinear interpolation is O(h^2) where phi is smooth).

A shape at the origin (sphere a = 1; box of half extents (0.9, 0.7, 0.5); torus about z with
R = 1, r = 0.4), a node grid of spacing h = h0 / refine over its bounding box plus 0.5 m
(h0 = 0.1 m), on which the engine samples the exact SDF, and n seeded probes drawn uniformly in
the grid and kept `clearance` x h0 (0.3 m) from where phi is not smooth: the sphere's centre;
the box's edges and corners and its inner medial surfaces (where two faces are nearest: kept
where the two largest face functions +-x_i - b_i differ by 2 clearance, or outside by the
clearance); the torus's core circle and its z axis (where rho = sqrt(x^2 + y^2) has a cone
point: every point of the axis is equally far from the whole core circle). The probes do not
depend on refine: the variants sphere, sphere_h2, sphere_h4 (and box, torus) are one batch on
three grids, and tests/cases/test_sdf_shapes.py fits the order over them.

The exact answers come from this module's own formulation, not the model's: the box by
projection (the nearest point clip(x, -b, b) outside, the nearest face inside), the torus by
the nearest point R (x, y, 0) / rho of the core circle.

Measures: `phi_err` (m, the tolerance column) max |phi_h - phi|; `phi_err_ratio` max
|phi_h - phi| / B_i; `grad_err_ratio` max |grad_h - grad| / G_i; `grad_norm_err` max
| |grad_h| - 1 | (|grad phi| = 1 away from the singular set); `grad_angle_deg` the largest
angle between grad_h and grad.

Bounds, per probe, on the probe's cell of side h (t its position in the cell, in [0, 1]^3),
where phi is C^{1,1} with Lambda >= the spectral norm of the Hessian on the cell (a.e.):
- trilinear = I_x + I_x (I_y - 1) + I_x I_y (I_z - 1) of linear interpolations with convex
  weights, each 1D error t (1 - t) h^2 / 2 max |phi_aa| (the Peano kernel): B_i = h^2 / 2
  sum_a t_a (1 - t_a) Lambda (<= 3 h^2 Lambda / 8);
- gradient, the x component: the x divided difference is the mean of phi_x over the edge,
  within h (t^2 + (1 - t)^2) / 2 max |phi_xx| of phi_x at the probe, and bilinear
  interpolation in y, z of a function Lipschitz with |phi_xy|, |phi_xz| <= Lambda adds
  2 t (1 - t) h Lambda per axis: G_i = h Lambda |w|, w_a = (t_a^2 + (1 - t_a)^2) / 2
  + 2 sum_{b != a} t_b (1 - t_b) (<= 1.5 sqrt 3 h Lambda);
- Lambda: sphere 1 / r_min ((I - n n^T) / |x|; r_min the cell's distance from the centre);
  torus max(1 / d_min, 1 / rho_min) (eigenvalues 0, 1 / d across the tube in the meridian
  plane, n_rho / rho around the axis; d_min = d(cell centre) - sqrt 3 h / 2, rho_min the
  cell's distance from the axis); box 0 where the whole cell is in one face's linear zone
  (max_{j != i} max q_j <= min(min q_i, 0), x_i of one sign), else 1 / dist(cell, edges)
  (0 in face zones, (I - n n^T) / dist in edge and corner zones);
- round-off: K eps S_i (K = 16, S_i = |lower| + |x| + |phi| + 2 h + size, sup norms: the nodes'
  and the probe's coordinates, the SDF's few operations, the nested blends), / h for the
  gradient; eps that of the engine's declared "precision" (float64 unless it says).
|grad_h| - 1 and the angle follow from |grad_h - grad| <= G_i (asin G_i for the angle).

Measured (refsim, h = 0.1, 0.05, 0.025, 0.0125 m): phi_err sphere 6.4e-3, 1.4e-3, 4.5e-4,
1.0e-4; box 7.9e-3, 1.9e-3, 5.0e-4, 1.2e-4; torus 4.4e-3, 1.2e-3, 2.8e-4, 7.0e-5 (fitted
orders 1.95, 2.01, 2.00; phi_err_ratio 0.75-0.97: the bound is nearly attained);
grad_norm_err 0.08-0.11 at h0 down to 0.009-0.014 (order 0.97-1.00); grad_err_ratio 0.43-0.70.

What it catches (planted, tests/cases/test_sdf_shapes.py, at refine 1 and 4): the grid sampled
half a cell off its declared origin (an O(h) error: phi_err_ratio 1.3e2-2e3 on the sphere and
the torus, 1e12 on the box, phi_err 0.02-0.09 m against 7e-4-0.02); the gradient's components
in the wrong axis order (z, y, x) (grad_angle_deg 177-180 against bounds of 10-90, every
shape); the shape 0.1 % too large (phi_err_ratio 3-93 on the sphere and the torus, 7e10 on the
box: the probes near nodes, where t (1 - t) makes B_i small); float32 node values: caught on
the box (phi_err_ratio 9e5, grad_err_ratio 7e5-2e6: its linear cells' bound is round-off
alone), not on the sphere or the torus, whose bounds at h >= 0.025 m (1e-4 m and up) are far
above float32's 6e-8 relative rounding.
"""
from __future__ import annotations

import math

import numpy as np

from refsim.case import EPS, Param
from refsim.query import QueryCase
from refsim.scene import Scene
from refsim.scene.queries import SdfProbes

SIZES = {"sphere": (1.0,), "box": (0.9, 0.7, 0.5), "torus": (1.0, 0.4)}
MARGIN = 0.5  # m of grid beyond the shape's bounding box
K_ROUNDING = 16  # round-off terms of the bound, with a margin of 2 (see the docstring)


def _extent(shape, size) -> np.ndarray:
    """Half sides of the shape's bounding box."""
    if shape == "torus":
        return np.array([size[0] + size[1], size[0] + size[1], size[1]])
    return np.broadcast_to(np.array(size, float), (3,)).copy()


# -- the exact SDFs (this case's own formulation) -----------------------------------------------
def exact_sdf(shape, size, x):
    """(phi (m,), grad (m, 3)) by nearest points."""
    if shape == "sphere":
        r = np.linalg.norm(x, axis=1)
        return r - size[0], x / r[:, None]
    if shape == "box":
        b = np.asarray(size)
        gap = x - np.clip(x, -b, b)
        out = np.linalg.norm(gap, axis=1)
        depth = b - np.abs(x)
        k = np.argmin(depth, axis=1)
        rows = np.arange(len(x))
        inner = np.zeros_like(x)
        inner[rows, k] = np.where(x[rows, k] < 0, -1.0, 1.0)
        outside = out > 0
        with np.errstate(invalid="ignore", divide="ignore"):
            grad = np.where(outside[:, None], gap / out[:, None], inner)
        return np.where(outside, out, -depth[rows, k]), grad
    core = x.copy()
    core[:, 2] = 0.0
    core *= size[0] / np.linalg.norm(core, axis=1)[:, None]
    v = x - core
    d = np.linalg.norm(v, axis=1)
    return d - size[1], v / d[:, None]


def _box_edge_distance(b, a):
    """Distance of points with |x| = a (m, 3) from the box's 12 edges."""
    dev = a - b
    out = []
    for i in range(3):
        rest = [j for j in range(3) if j != i]
        out.append(np.sqrt(np.maximum(dev[:, i], 0.0) ** 2 + np.sum(dev[:, rest] ** 2, 1)))
    return np.min(out, axis=0)


def clearance(shape, size, x) -> np.ndarray:
    """(m,) a lower bound on each point's distance from the shape's singular set."""
    if shape == "sphere":
        return np.linalg.norm(x, axis=1)
    if shape == "torus":
        rho = np.hypot(x[:, 0], x[:, 1])
        return np.minimum(rho, np.hypot(rho - size[0], x[:, 2]))
    b, a = np.asarray(size), np.abs(x)
    faces = np.sort(np.concatenate([a - b, -a - b], axis=1), axis=1)
    medial = np.maximum((faces[:, -1] - faces[:, -2]) / 2, exact_sdf(shape, size, x)[0])
    return np.minimum(_box_edge_distance(b, a), medial)


def hessian_bound(shape, size, lo, h) -> np.ndarray:
    """(m,) Lambda: the Hessian's spectral norm bounded over each cell [lo, lo + h]^3."""
    hi = lo + h
    near = np.maximum(np.maximum(lo, -hi), 0.0)  # per axis, the cell's distance from 0
    half_diagonal = math.sqrt(3) * h / 2
    if shape == "sphere":
        return 1.0 / np.linalg.norm(near, axis=1)
    centre = lo + h / 2
    if shape == "torus":
        rho_min = np.hypot(near[:, 0], near[:, 1])
        d_min = np.hypot(np.hypot(centre[:, 0], centre[:, 1]) - size[0], centre[:, 2]) \
            - half_diagonal
        return np.maximum(1.0 / d_min, 1.0 / rho_min)
    b = np.asarray(size)
    q_max = np.maximum(np.abs(lo), np.abs(hi)) - b
    q_min = np.minimum(np.abs(lo), np.abs(hi)) - b
    one_sign = (lo >= 0) | (hi <= 0)
    linear = np.zeros(len(lo), bool)
    for i in range(3):
        rest = [j for j in range(3) if j != i]
        linear |= one_sign[:, i] & (q_max[:, rest].max(1) <= np.minimum(q_min[:, i], 0.0))
    edges = _box_edge_distance(b, np.abs(centre)) - half_diagonal
    return np.where(linear, 0.0, 1.0 / edges)


class SdfShapesCase(QueryCase):
    name = "sdf_shapes"
    description = ("trilinear grid SDF of a sphere, box and torus against the exact distance "
                   "and gradient, O(h^2) over refinements")
    tags = ("collision", "queries", "sdf", "exact")
    answers = ("phi", "grad")
    measures = {"phi_err": ("m", "max |phi_h - phi| over the probes"),
                "phi_err_ratio": ("of B_i", "max |phi_h - phi| / B_i (each probe's bound)"),
                "grad_err_ratio": ("of G_i", "max |grad_h - grad| / G_i (each probe's bound)"),
                "grad_norm_err": ("1", "max | |grad phi_h| - 1 |"),
                "grad_angle_deg": ("deg", "max angle between grad phi_h and grad phi")}
    params = {
        "shape": Param("sphere", choices=tuple(SIZES), doc="the analytic shape"),
        "refine": Param(1, 1, 16, "grid refinement (an integer): h = h0 / refine"),
        "h0": Param(0.1, 0.02, 0.2, "the coarsest node spacing (m)"),
        "n": Param(2000, 10, 1e6, "probes in the batch"),
        "seed": Param(1, 0, 2 ** 31, "random seed"),
        "clearance": Param(3.0, 2.0, 20.0, "probes' least distance from the singular set, in "
                                           "h0 (> sqrt 3: no cell at h0 reaches it)"),
    }
    variants = {**{f"{s}{tag}": {"shape": s, "refine": r} for s in SIZES
                   for tag, r in (("", 1), ("_h2", 2), ("_h4", 4))},
                "torus_many": {"shape": "torus", "n": 1e5}}
    default_variants = ("sphere", "box", "torus", "sphere_h4")
    quick_variants = ("sphere", "box", "torus")
    # order_meaningful = False: one answer of the batch, no time step (the order in h is the
    # refinements', fitted in tests/cases/test_sdf_shapes.py)

    # -- the batch ------------------------------------------------------------------------------
    def batch(self, p) -> int:
        return int(p["n"])

    def grid(self, p) -> tuple:
        """(lower (3,), h, nodes (3,)) of the variant's grid."""
        refine = int(round(p["refine"]))
        if refine != p["refine"]:
            raise ValueError(f"sdf_shapes.refine must be an integer, got {p['refine']}")
        half = _extent(p["shape"], SIZES[p["shape"]]) + MARGIN
        cells = np.ceil(np.round(2 * half / p["h0"], 9)).astype(int)
        return -cells * p["h0"] / 2, p["h0"] / refine, tuple(int(c) for c in cells * refine + 1)

    def probes(self, p) -> np.ndarray:
        """(n, 3) seeded probes in the grid, clearance h0 from the singular set (not
        depending on refine)."""
        shape, size = p["shape"], SIZES[p["shape"]]
        lower, _, _ = self.grid({**p, "refine": 1})
        rng = np.random.default_rng(int(p["seed"]))
        n, keep = int(p["n"]), []
        while sum(map(len, keep)) < n:
            x = rng.uniform(lower, -lower, (2 * n, 3))
            keep.append(x[clearance(shape, size, x) >= p["clearance"] * p["h0"]])
        return np.concatenate(keep)[:n]

    def scene(self, p):
        lower, h, nodes = self.grid(p)
        part = SdfProbes(p["shape"], SIZES[p["shape"]], lower, h, nodes, self.probes(p))
        return Scene(parts=(part,), dim=3)

    # -- answers --------------------------------------------------------------------------------
    def exact(self, p) -> dict:
        shape, size = p["shape"], SIZES[p["shape"]]
        x = self.probes(p)
        lower, h, nodes = self.grid(p)
        index = np.clip(np.floor((x - lower) / h).astype(np.int64), 0, np.array(nodes) - 2)
        lo = lower + h * index
        t = (x - lower) / h - index
        lam = hessian_bound(shape, size, lo, h)
        s = t * (1 - t)
        w = (t * t + (1 - t) ** 2) / 2 + 2 * (s.sum(1)[:, None] - s)
        phi, grad = exact_sdf(shape, size, x)
        scale = (np.abs(lower).max() + np.abs(x).max(1) + np.abs(phi) + 2 * h + max(size))
        return {"phi": phi, "grad": grad, "interp": h * h / 2 * s.sum(1) * lam,
                "interp_grad": h * lam * np.linalg.norm(w, axis=1), "scale": scale, "h": h}

    @staticmethod
    def _per_probe(exact, eps) -> tuple:
        rounding = K_ROUNDING * eps * exact["scale"]
        return exact["interp"] + rounding, exact["interp_grad"] + rounding / exact["h"]

    def measure(self, p, answered, exact) -> dict:
        phi_h, grad_h = np.asarray(answered["phi"], float), np.asarray(answered["grad"], float)
        bound, bound_grad = self._per_probe(exact, EPS)
        err = np.abs(phi_h - exact["phi"])
        err_grad = np.linalg.norm(grad_h - exact["grad"], axis=1)
        norm = np.linalg.norm(grad_h, axis=1)
        cos = np.einsum("nk,nk->n", grad_h, exact["grad"]) / norm
        return {"phi_err": float(err.max()), "phi_err_ratio": float(np.max(err / bound)),
                "grad_err_ratio": float(np.max(err_grad / bound_grad)),
                "grad_norm_err": float(np.abs(norm - 1).max()),
                "grad_angle_deg": float(np.degrees(np.arccos(np.clip(cos, -1, 1))).max())}

    def bounds(self, p, settings) -> dict:
        eps = float(np.finfo(np.dtype((settings or {}).get("precision", "float64"))).eps)
        exact = self.exact_cached(p)
        bound, bound_grad = self._per_probe(exact, eps)
        ref, ref_grad = self._per_probe(exact, EPS)
        wider = "" if eps == EPS else f" (at the declared precision's eps {eps:.3g})"
        return {
            "phi_err": (float(bound.max()), "trilinear h^2/2 sum t(1-t) Lambda + round-off "
                                            "K eps S, largest over the probes" + wider),
            "phi_err_ratio": (float(np.max(bound / ref)), "each probe within its own bound "
                                                          "B_i" + wider),
            "grad_err_ratio": (float(np.max(bound_grad / ref_grad)),
                               "each probe within its own bound G_i" + wider),
            "grad_norm_err": (float(bound_grad.max()), "| |g_h| - 1 | <= |g_h - g| <= G_i"),
            "grad_angle_deg": (float(np.degrees(np.arcsin(np.minimum(bound_grad, 1))).max()),
                               "angle <= asin G_i")}

    def motion_scale(self, p) -> float:
        return float(max(SIZES[p["shape"]]))


CASE = SdfShapesCase()
