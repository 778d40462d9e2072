"""The in-house engine's convex pair queries (issue 28): separating axes for a `PolygonPairs`
batch (2D) or a `BoxPairs` batch (3D), one vectorised call per batch (refsim.models.collision.
sat; the exact distance of separated pairs from their features). One integrator, "query"."""
from __future__ import annotations

from refsim.query import QuerySim, query_group
from refsim.scene.queries import BoxPairs, PolygonPairs


class PairSim(QuerySim):
    names = ("overlap", "distance", "normal")

    def __init__(self, part, dt):
        super().__init__(dt)
        self.part = part

    def answer(self):
        from refsim.models.collision import sat
        q = self.part
        if isinstance(q, PolygonPairs):
            return sat.polygon_pairs(q.a, q.a_count, q.b, q.b_count)
        return sat.box_pairs(q.a_center, q.a_half, q.a_rotation, q.b_center, q.b_half,
                             q.b_rotation)

    def settings(self):
        from refsim.models.collision.sat import PARALLEL_SIN
        boxes = isinstance(self.part, BoxPairs)
        return {"integrator": {"name": "query", "order": 0},
                "algorithm": ("SAT over the 15 axes (3 + 3 face normals, 9 edge cross products); "
                              "apart: least vertex-box and edge-edge distance" if boxes else
                              "SAT over both polygons' edge normals; apart: least vertex-edge "
                              "distance both ways"),
                **({"parallel_sin": PARALLEL_SIN} if boxes else {}),
                "distance_tolerance": 0.0, "precision": "float64"}


def _part(scene):
    return scene.part(PolygonPairs) or scene.part(BoxPairs)


def _build(engine, scene, dt, integrator, formulation):
    return PairSim(_part(scene), dt)


MODEL_GROUP = query_group("collision_pairs", (PolygonPairs, BoxPairs), _build)
