"""The in-house engine's BVH queries (issue 28): a bounding volume hierarchy over the primitive
spheres of a `BvhQueries` batch (refsim.models.collision.bvh), built once when the Sim is built
(the row's setup_s), then per batch both queries: every overlapping (query, primitive) pair and
each query centre's nearest primitive surface. Formulations, the split rule: "morton" (radix
splits on the Morton order, the LBVH tree) and "median" (object median on each node's widest
axis). One integrator, "query" (refsim.query)."""
from __future__ import annotations

from refsim.query import QuerySim, query_group
from refsim.scene.queries import BvhQueries

LEAF_SIZE = 8  # primitives per leaf at most


class BvhSim(QuerySim):
    names = ("pairs", "nearest", "nearest_distance")

    def __init__(self, part, dt, split):
        from refsim.models.collision.bvh import build
        super().__init__(dt)
        self.part = part
        self.tree = build(part.prim_center, part.prim_radius, LEAF_SIZE, split)

    def answer(self):
        from refsim.models.collision.bvh import nearest, overlap_pairs
        q = self.part
        pairs = overlap_pairs(self.tree, q.query_center, q.query_radius)
        index, distance = nearest(self.tree, q.query_center)
        return {"pairs": pairs.astype(float), "nearest": index.astype(float),
                "nearest_distance": distance}

    def settings(self):
        from refsim.models.collision.bvh import PAD_EPS
        return {"integrator": {"name": "query", "order": 0},
                "algorithm": f"BVH over the primitive spheres' boxes, split {self.tree.split!r}"
                             f", leaves of at most {LEAF_SIZE}; overlap: AABB-pruned frontier "
                             "then the exact sphere test; nearest: batched branch and bound",
                "split": self.tree.split, "leaf_size": LEAF_SIZE,
                "depth": self.tree.depth, "round_off_pad": self.tree.pad,
                "round_off_pad_eps": PAD_EPS, "overlap_margin": 0.0,
                "precision": "float64"}



def formulations(engine, scene):
    from refsim.models.collision.bvh import SPLITS
    return SPLITS


def _build(engine, scene, dt, integrator, formulation):
    return BvhSim(scene.part(BvhQueries), dt, formulation or "morton")


MODEL_GROUP = query_group("collision_bvh", (BvhQueries,), _build, formulations=formulations)
