"""The in-house engine's grid signed distance fields (issue 28): an `SdfProbes` scene's exact
SDF sampled once on its node grid at build (setup_s), then every probe's trilinear value and
the interpolant's own gradient in one vectorised call per batch
(refsim.models.collision.sdf). One integrator, "query" (refsim.query)."""
from __future__ import annotations

import numpy as np

from refsim.query import QuerySim, query_group
from refsim.scene.queries import SdfProbes


class SdfSim(QuerySim):
    names = ("phi", "grad")

    def __init__(self, part, dt):
        from refsim.models.collision.sdf import sample
        super().__init__(dt)
        self.part = part
        self.values = sample(part.shape, part.size, part.lower, part.h, part.nodes)

    def answer(self):
        from refsim.models.collision.sdf import trilinear
        q = self.part
        phi, grad = trilinear(self.values, q.lower, q.h, q.points)
        return {"phi": phi, "grad": grad}

    def settings(self):
        return {"integrator": {"name": "query", "order": 0},
                "algorithm": "exact SDF sampled at the nodes; trilinear interpolation, the "
                             "gradient the interpolant's own (piecewise bilinear)",
                "grid_nodes": list(self.part.nodes), "h": self.part.h,
                "precision": str(np.dtype(self.values.dtype))}



def _build(engine, scene, dt, integrator, formulation):
    return SdfSim(scene.part(SdfProbes), dt)


MODEL_GROUP = query_group("collision_sdf", (SdfProbes,), _build)
