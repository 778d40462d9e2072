"""The in-house engine's swept-sphere queries (issue 28): the closed-form time of impact of
each pair of a `SweptSpheres` batch (refsim.models.collision.swept), one vectorised call per
batch. One integrator, "query" (refsim.query)."""
from __future__ import annotations

from refsim.query import QuerySim, query_group
from refsim.scene.queries import SweptSpheres


class SweptSim(QuerySim):
    names = ("toi",)

    def __init__(self, part, dt):
        super().__init__(dt)
        self.part = part

    def answer(self):
        from refsim.models.collision.swept import time_of_impact
        q = self.part
        return {"toi": time_of_impact(q.c1, q.v1, q.r1, q.c2, q.v2, q.r2, q.t_max)}

    def settings(self):
        return {"integrator": {"name": "query", "order": 0},
                "algorithm": "closed-form root of |p + v t| = r1 + r2, the cancellation-free "
                             "form t = c / (sqrt(b^2 - a c) - b)", "precision": "float64"}



def _build(engine, scene, dt, integrator, formulation):
    return SweptSim(scene.part(SweptSpheres), dt)


MODEL_GROUP = query_group("collision_swept", (SweptSpheres,), _build)
