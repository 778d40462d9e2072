"""Geometric query batches (issue 28, collision detection): parts that hold a batch of queries
with exact answers and no time stepping. One step of a query scene answers the whole batch
(refsim.query: QueryCase, QuerySim); `len(part)` is the batch size.

Parts (kinds) and the answers an engine observes for them, as "query.<name>" (SI units):
- PolygonPairs ("polygon_pairs", 2D): n pairs of convex polygons, counter-clockwise, vertices
  in world coordinates, padded to a common count k (rows past `a_count[i]` / `b_count[i]` are
  ignored). Answers: "query.overlap" (n,) 1.0 where the closed polygons intersect, else 0.0;
  "query.distance" (n,) m, the signed distance: the gap between the closest points when apart,
  minus the penetration depth (the shortest translation of B that separates them) when they
  overlap; "query.normal" (n, 2) unit: from A towards B (translating B by -distance x normal
  makes them touch).
- BoxPairs ("box_pairs", 3D): n pairs of oriented boxes: centre (n, 3), half extents (n, 3)
  > 0, rotation (n, 3, 3) body to world (columns the box axes, orthonormal, det +1). Answers
  as for PolygonPairs with (n, 3) normals.
- SdfProbes ("sdf_probes", 3D): one analytic shape (sphere: size (radius,); box: (hx, hy,
  hz); torus: (R, r) about z) centred at the origin, a node grid (`lower` corner, spacing
  `h`, `nodes` per axis) on which the engine samples the exact signed distance, and m probe
  points inside the grid. Answers: "query.phi" (m,) m, the grid SDF interpolated at each
  point; "query.grad" (m, 3), its gradient (the interpolant's own).
- BvhQueries ("bvh_queries", 3D): N primitive spheres and M query spheres. Answers:
  "query.pairs" (k, 2) int as float, every (query, primitive) pair that overlaps
  (|c_q - c_p| <= r_q + r_p), sorted by query then primitive; "query.nearest" (M,) the index
  of the primitive whose surface is nearest each query centre (|c_q - c_p| - r_p least),
  "query.nearest_distance" (M,) m that distance.
- SweptSpheres ("sphere_sweeps", 3D): n pairs of spheres moving at constant velocity over
  [0, t_max]. Answers: "query.toi" (n,) s, the first time |c1 + v1 t - c2 - v2 t| = r1 + r2
  in [0, t_max] (0 where they overlap at t = 0, NaN where they never touch in the window).

A query scene holds one such part and nothing else; its feature is "queries".
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._validate import (ArrayPart, _positive, _set, choice, float_array, positive_array,
                        read_only)

QUERY_KINDS = ("polygon_pairs", "box_pairs", "sdf_probes", "bvh_queries", "sphere_sweeps")
SDF_SHAPES = {"sphere": 1, "box": 3, "torus": 2}  # shape -> number of size parameters
ROTATION_ROUND_OFF = 1e-12  # |R^T R - I| and |det R - 1| allowed: rotations built in float64


class QueryPart(ArrayPart):
    """Base of the query parts: feature "queries"; len() is the batch size."""

    def features(self) -> set[str]:
        return {"queries"}


def _counts(name, value, n, k) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (n,) or not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr)):
        raise ValueError(f"{name} must be {n} integers, got {np.asarray(value)!r:.80}")
    arr = arr.astype(np.int64)
    if n and (arr.min() < 3 or arr.max() > k):
        raise ValueError(f"{name} must be in [3, {k}], got {arr.min()}..{arr.max()}")
    return read_only(arr)


def _check_convex(name, vertices, counts) -> None:
    """Counter-clockwise and strictly convex: every turn (cross product of consecutive edges)
    > 0 over each polygon's own vertices."""
    n, k, _ = vertices.shape
    idx = np.arange(k)[None, :]
    cnt = counts[:, None]
    nxt = np.where(idx + 1 < cnt, idx + 1, 0)
    nxt2 = np.where(nxt + 1 < cnt, nxt + 1, 0)
    rows = np.arange(n)[:, None]
    e1 = vertices[rows, nxt] - vertices
    e2 = vertices[rows, nxt2] - vertices[rows, nxt]
    turn = e1[..., 0] * e2[..., 1] - e1[..., 1] * e2[..., 0]
    bad = (turn <= 0) & (idx < cnt)
    if bad.any():
        raise ValueError(f"{name} must be convex and counter-clockwise (a positive turn at "
                         f"every vertex), polygon {int(np.argwhere(bad)[0, 0])} is not")


@dataclass(frozen=True, eq=False)
class PolygonPairs(QueryPart):
    """n pairs of convex counter-clockwise polygons (2D), padded to k vertices."""

    a: np.ndarray
    a_count: np.ndarray
    b: np.ndarray
    b_count: np.ndarray

    kind = "polygon_pairs"

    def __post_init__(self):
        a = float_array("polygon_pairs.a", self.a, (None, None, 2))
        n, k, _ = a.shape
        b = float_array("polygon_pairs.b", self.b, (n, None, 2))
        for side, verts in (("a", a), ("b", b)):
            count = _counts(f"polygon_pairs.{side}_count", getattr(self, f"{side}_count"), n,
                            verts.shape[1])
            _check_convex(f"polygon_pairs.{side}", verts, count)
            _set(self, side, verts)
            _set(self, f"{side}_count", count)

    def __len__(self) -> int:
        return len(self.a)


def rotations(name: str, value, n: int) -> np.ndarray:
    """(n, 3, 3) rotation matrices: orthonormal and det +1 to ROTATION_ROUND_OFF."""
    rot = float_array(name, value, (n, 3, 3))
    if n:
        gram = np.einsum("nki,nkj->nij", rot, rot) - np.eye(3)
        det = np.linalg.det(rot)
        if np.abs(gram).max() > ROTATION_ROUND_OFF or np.abs(det - 1).max() > ROTATION_ROUND_OFF:
            raise ValueError(f"{name} must be rotations (R^T R = I, det R = 1 within "
                             f"{ROTATION_ROUND_OFF:g})")
    return rot


@dataclass(frozen=True, eq=False)
class BoxPairs(QueryPart):
    """n pairs of oriented boxes (3D): centres, half extents, rotations (body to world)."""

    a_center: np.ndarray
    a_half: np.ndarray
    a_rotation: np.ndarray
    b_center: np.ndarray
    b_half: np.ndarray
    b_rotation: np.ndarray

    kind = "box_pairs"

    def __post_init__(self):
        n = len(float_array("box_pairs.a_center", self.a_center, (None, 3)))
        for side in ("a", "b"):
            _set(self, f"{side}_center", float_array(f"box_pairs.{side}_center",
                                                     getattr(self, f"{side}_center"), (n, 3)))
            _set(self, f"{side}_half", positive_array(f"box_pairs.{side}_half",
                                                      getattr(self, f"{side}_half"), (n, 3)))
            _set(self, f"{side}_rotation", rotations(f"box_pairs.{side}_rotation",
                                                     getattr(self, f"{side}_rotation"), n))

    def __len__(self) -> int:
        return len(self.a_center)


@dataclass(frozen=True, eq=False)
class SdfProbes(QueryPart):
    """An analytic shape at the origin, the node grid its SDF is sampled on, probe points."""

    shape: str
    size: np.ndarray
    lower: np.ndarray
    h: float
    nodes: tuple
    points: np.ndarray

    kind = "sdf_probes"

    def __post_init__(self):
        choice("sdf_probes.shape", self.shape, tuple(SDF_SHAPES))
        _set(self, "size", positive_array("sdf_probes.size", np.atleast_1d(self.size),
                                          (SDF_SHAPES[self.shape],)))
        _set(self, "lower", float_array("sdf_probes.lower", self.lower, (3,)))
        _set(self, "h", _positive("sdf_probes.h", self.h))
        nodes = tuple(int(c) for c in self.nodes)
        if len(nodes) != 3 or min(nodes) < 2 or tuple(self.nodes) != nodes:
            raise ValueError(f"sdf_probes.nodes must be 3 integers >= 2, got {self.nodes!r}")
        _set(self, "nodes", nodes)
        points = float_array("sdf_probes.points", self.points, (None, 3))
        upper = self.lower + self.h * (np.array(nodes) - 1)
        if len(points) and ((points < self.lower).any() or (points > upper).any()):
            raise ValueError(f"sdf_probes.points must lie in the grid [{self.lower.tolist()}, "
                             f"{upper.tolist()}]")
        _set(self, "points", points)

    def __len__(self) -> int:
        return len(self.points)


@dataclass(frozen=True, eq=False)
class BvhQueries(QueryPart):
    """N primitive spheres, M query spheres (3D)."""

    prim_center: np.ndarray
    prim_radius: np.ndarray
    query_center: np.ndarray
    query_radius: np.ndarray

    kind = "bvh_queries"

    def __post_init__(self):
        big = len(float_array("bvh_queries.prim_center", self.prim_center, (None, 3)))
        small = len(float_array("bvh_queries.query_center", self.query_center, (None, 3)))
        if big == 0:
            raise ValueError("bvh_queries.prim_center must hold at least one primitive")
        for name, count in (("prim", big), ("query", small)):
            _set(self, f"{name}_center", float_array(f"bvh_queries.{name}_center",
                                                     getattr(self, f"{name}_center"), (count, 3)))
            _set(self, f"{name}_radius", positive_array(f"bvh_queries.{name}_radius",
                                                        getattr(self, f"{name}_radius"),
                                                        (count,)))

    def __len__(self) -> int:
        return len(self.query_center)


@dataclass(frozen=True, eq=False)
class SweptSpheres(QueryPart):
    """n pairs of spheres at constant velocity over the window [0, t_max] (3D)."""

    c1: np.ndarray
    v1: np.ndarray
    r1: np.ndarray
    c2: np.ndarray
    v2: np.ndarray
    r2: np.ndarray
    t_max: float = 1.0

    kind = "sphere_sweeps"

    def __post_init__(self):
        n = len(float_array("sphere_sweeps.c1", self.c1, (None, 3)))
        for name in ("c1", "v1", "c2", "v2"):
            _set(self, name, float_array(f"sphere_sweeps.{name}", getattr(self, name), (n, 3)))
        for name in ("r1", "r2"):
            _set(self, name, positive_array(f"sphere_sweeps.{name}", getattr(self, name), (n,)))
        _set(self, "t_max", _positive("sphere_sweeps.t_max", self.t_max))

    def __len__(self) -> int:
        return len(self.c1)
