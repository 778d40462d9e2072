"""pymunk's answers to the polygon-pair queries (issue 28): signed distance, overlap and normal
of each pair of a `PolygonPairs` batch, from pymunk's own per-shape queries. One integrator,
"query" (refsim.query).

Build (setup_s): one static `pymunk.Body` at the origin (identity transform: the world
vertices reach Chipmunk unchanged), and per polygon one `pymunk.Poly(body, vertices,
radius=0)` with the vertices as given, `cache_bb()` called once (it fills the transformed
vertices the queries read; no Space, nothing stepped). Chipmunk keeps the convex hull of the
vertices (tolerance 0): a strictly convex polygon keeps every vertex (checked at build).

Answer, per pair (one Python call or more per pair: pymunk's API is per query, and that loop
IS its cost from Python):
- `a.shapes_collide(b)`: Chipmunk's narrow phase (GJK, then EPA when the Minkowski difference
  holds the origin; at most 30 iterations each, src/cpCollision.c). Contacts exist when the
  closest-point distance is <= 0 (radius 0); the answer is the ContactPointSet's normal (A
  towards B, the minimum separating axis) and the least `distance` of its points (the deepest;
  negative: minus the penetration depth). For separated shapes the set has no points and
  pymunk raises AssertionError ("likely a bug in Pymunk"): caught, and the pair is a miss.
- a miss: the least of `point_query` distances of A's vertices against B and B's vertices
  against A. The distance between two separated convex polygons is attained at a vertex of
  one of them (it is the least distance between an edge of A and an edge of B, and two
  disjoint segments are closest at an endpoint of one), so this is exact. The normal is that
  query's gradient (the unit vector from the closest point of the queried shape to the
  vertex): negated for a vertex of A against B, as is for a vertex of B against A. Chipmunk
  returns the closest edge's normal instead when the gap is <= MAGIC_EPSILON = 1e-5 m
  (cpPolyShape.c): wrong only where the closest features are two vertices closer than that.
- overlap: 1.0 where the signed distance is <= 0.

Measured (pymunk 7.3.1, Chipmunk 2.0.1, 3000 random convex pairs of 3-8 vertices against a
brute-force SAT and vertex-edge oracle): distances within 4.4e-16 m, normals within round-off,
both for contacts and misses; about 10 us per overlapping pair, 4 us + 2k x 5.6 us per
separated pair of k-gons (docs/engine_notes.md#pymunk-polygon-pair-queries).
Under `python -O` the assert is gone and a miss would read stale contacts: the group refuses.
"""
from __future__ import annotations

import numpy as np

from refsim.query import QuerySim, query_group
from refsim.scene.queries import PolygonPairs

MAGIC_EPSILON = 1e-5  # Chipmunk's gap below which point_query's gradient is the edge normal
GJK_MAX_ITERATIONS = EPA_MAX_ITERATIONS = 30  # src/cpCollision.c


class PymunkPolygonSim(QuerySim):
    names = ("overlap", "distance", "normal")

    def __init__(self, pymunk, part: PolygonPairs, dt):
        super().__init__(dt)
        self.version = (pymunk.version, pymunk.chipmunk_version)
        body = pymunk.Body(body_type=pymunk.Body.STATIC)
        self.vertices, self.shapes = [], []
        for verts, counts in ((part.a, part.a_count), (part.b, part.b_count)):
            side_v, side_s = [], []
            for poly, k in zip(verts, counts):
                pts = [tuple(v) for v in poly[:k].tolist()]
                shape = pymunk.Poly(body, pts, radius=0.0)
                shape.cache_bb()
                if len(shape.get_vertices()) != k:
                    raise ValueError(f"pymunk's hull of a {k}-gon kept "
                                     f"{len(shape.get_vertices())} vertices")
                side_v.append(pts)
                side_s.append(shape)
            self.vertices.append(side_v)
            self.shapes.append(side_s)
        self.body = body  # Chipmunk shapes keep a pointer to it: keep it alive
        self.n = len(part)

    def _miss(self, i):
        """Least vertex-against-shape distance of a separated pair, and its normal A -> B."""
        (va, vb), (a, b) = (self.vertices[0][i], self.vertices[1][i]), \
            (self.shapes[0][i], self.shapes[1][i])
        best, normal = np.inf, (np.nan, np.nan)
        for v in va:
            q = b.point_query(v)
            if q.distance < best:
                best, normal = q.distance, (-q.gradient.x, -q.gradient.y)
        for v in vb:
            q = a.point_query(v)
            if q.distance < best:
                best, normal = q.distance, (q.gradient.x, q.gradient.y)
        return best, normal

    def answer(self):
        dist = np.empty(self.n)
        normal = np.empty((self.n, 2))
        shapes_a, shapes_b = self.shapes
        for i in range(self.n):
            try:
                hit = shapes_a[i].shapes_collide(shapes_b[i])
            except AssertionError:  # separated: pymunk's way of saying "no contact points"
                dist[i], normal[i] = self._miss(i)
                continue
            dist[i] = min(p.distance for p in hit.points)
            normal[i] = hit.normal.x, hit.normal.y
        return {"overlap": (dist <= 0).astype(float), "distance": dist, "normal": normal}

    def settings(self):
        return {
            "integrator": {"name": "query", "order": 0},
            "algorithm": ("contacts: Shape.shapes_collide (Chipmunk GJK + EPA), distance the "
                          "least ContactPoint.distance, normal ContactPointSet.normal; misses "
                          "(AssertionError: no contact points): the least Shape.point_query "
                          "distance of each polygon's vertices against the other, normal its "
                          "gradient (negated for A's vertices); overlap = distance <= 0"),
            "shapes": "one static Body at the origin, one Poly per polygon, vertices as given",
            "poly_radius": 0.0,
            "collision_margin": 0.0,
            "collision_slop": ("not applied: Space.collision_slop (0.1 by default) acts in the "
                               "contact solver, not in shapes_collide or point_query"),
            "gjk_max_iterations": GJK_MAX_ITERATIONS,
            "epa_max_iterations": EPA_MAX_ITERATIONS,
            "gradient_edge_normal_below": MAGIC_EPSILON,
            "loop": ("one Python call of pymunk's per-query API per pair (shapes_collide), "
                     "plus one point_query per vertex of a separated pair: the real cost of "
                     "pymunk from Python"),
            "precision": "float64 (cpFloat is double)",
            "pymunk": self.version[0], "chipmunk": self.version[1],
        }



def supports(engine, scene, integrator):
    if not __debug__:
        return ("pymunk reports a separated pair only by an assert in ContactPointSet; under "
                "python -O it reads stale contact points")
    return None


def _build(engine, scene, dt, integrator, formulation):
    import pymunk  # lazily: refsim works without pymunk installed
    return PymunkPolygonSim(pymunk, scene.part(PolygonPairs), dt)


MODEL_GROUP = query_group("collision_polygons", (PolygonPairs,), _build, supports=supports)
