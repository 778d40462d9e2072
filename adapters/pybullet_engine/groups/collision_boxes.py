"""pybullet's answers to the box-pair queries (issue 28): signed distance, overlap and normal of
each pair of a `BoxPairs` batch. One integrator, "query" (refsim.query); two formulations, the
two narrow phases pybullet exposes for a pair of boxes:

- "" (default): `performCollisionDetection` once per batch, then per pair `getContactPoints`:
  Bullet's box-box detector (btBoxBoxDetector, ODE's dBoxBox: the 15 SAT axes on the full
  half extents), the deepest point's distance and its normal; pairs with no contact point are
  separated and get `getClosestPoints` (below).
- "closest_points": `getClosestPoints(a, b, distance)` for every pair: Bullet's GJK, and EPA
  when the shapes overlap (btConvexConvexAlgorithm: pybullet's closest-point queries take it
  for box pairs, not the box-box detector).

Build (setup_s): DIRECT clients of at most CHUNK pairs each, no gravity, never stepped; per box one GEOM_BOX collision
shape (the half extents) and one multibody of mass 1 at the centre, orientation the rotation's
quaternion (mass 0 would make the pair static-static, which Bullet's dispatcher never
collides); every body's collision filter mask 0 and each pair re-enabled by
setCollisionFilterPair, so performCollisionDetection collides the batch's pairs and nothing
else. Per pair the answer costs one or two Python calls: pybullet's API is per pair, and that
loop IS its cost from Python.

Conventions: pybullet's [8] is the signed distance (negative: penetration), [7] the contact
normal on B pointing towards A: refsim's normal (A towards B) is -[7]. overlap = distance <= 0.

What each narrow phase answers (pybullet 3.2.7, measured, docs/engine_notes.md):
- GJK/EPA sees the box with its collision margin m (0.001 m, pybullet's default for a box:
  getDynamicsInfo's last entry) as the box of half extents h - m swept by a sphere of radius
  m: edges and corners rounded. Faces are exact; the distance is larger than the boxes' by
  at most m (sqrt 3 - 1) per box (the rounded box's Hausdorff distance to the box):
  "distance_tolerance" = 2 m (sqrt 3 - 1) = 1.46e-3 m. Box vs 45-degree box: 0.793307 against
  0.7928932 = exact + m (sqrt 2 - 1). A zero margin (changeDynamics collisionMargin=0) makes
  separated pairs exact but breaks EPA (0.075 m off at 0.2 m depth): not used.
- the box-box detector takes the full half extents (exact faces and edges) but keeps a face
  axis unless an edge-edge axis is 5 % shallower (fudge_factor 1.05) and adds 1e-5 to every
  |R_ij| on the edge axes (fudge2): a reported depth up to 5 % deeper than the least
  separating translation, along a face normal where the answer is an edge-edge axis (normal
  off by tens of degrees). Declared as "depth_relative_tolerance" 0.05.
"""
from __future__ import annotations

import contextlib
import math

import numpy as np

from refsim.models.rigid_body import matrix_to_quaternion
from refsim.query import QuerySim, query_group
from refsim.scene.queries import BoxPairs

from ..runtime import OwnsClient, c_stdout_silenced, import_pybullet

FORMULATIONS = ("", "closest_points")
FUDGE_FACTOR, FUDGE2 = 1.05, 1e-5  # btBoxBoxDetector.cpp (dBoxBox2)
# pairs per physics client: createMultiBody costs more the more bodies its world holds (CPU
# 0.20 ms a body at 1000 bodies, 0.44 ms at 8000), so the batch is split into worlds of this size
CHUNK = 500


class PybulletBoxSim(OwnsClient, QuerySim):
    names = ("overlap", "distance", "normal")

    def __init__(self, p, part: BoxPairs, dt, formulation: str):
        super().__init__(dt)
        self.p, self.formulation, self.n = p, formulation, len(part)
        quats = [matrix_to_quaternion(part.a_rotation)[:, [1, 2, 3, 0]].tolist(),
                 matrix_to_quaternion(part.b_rotation)[:, [1, 2, 3, 0]].tolist()]
        centres = [part.a_center.tolist(), part.b_center.tolist()]
        halves = [part.a_half.tolist(), part.b_half.tolist()]
        self.clients, self.pairs, margins = [], [], set()
        for start in range(0, self.n, CHUNK):
            with c_stdout_silenced():
                cid = p.connect(p.DIRECT)
            self.clients.append(cid)
            p.setGravity(0.0, 0.0, 0.0, physicsClientId=cid)
            for i in range(start, min(start + CHUNK, self.n)):
                a, b = (self._box(cid, centres[s][i], halves[s][i], quats[s][i]) for s in (0, 1))
                p.setCollisionFilterPair(a, b, -1, -1, 1, physicsClientId=cid)
                self.pairs.append((cid, a, b))
                margins.add(p.getDynamicsInfo(a, -1, physicsClientId=cid)[-1])
                margins.add(p.getDynamicsInfo(b, -1, physicsClientId=cid)[-1])
        self.client = self.clients[0] if self.clients else None
        self.margin = max(margins) if margins else 0.0
        # the closest-point threshold: beyond every pair's gap (at most the centres' distance)
        reach = np.linalg.norm(part.b_center - part.a_center, axis=1) if self.n else [0.0]
        self.threshold = float(np.max(reach)) + 1.0

    def _box(self, cid, centre, half, quat):
        p = self.p
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=cid)
        body = p.createMultiBody(1.0, shape, basePosition=centre, baseOrientation=quat,
                                 physicsClientId=cid)
        p.setCollisionFilterGroupMask(body, -1, 0, 0, physicsClientId=cid)
        return body

    def close(self):
        for cid in getattr(self, "clients", ()):
            with contextlib.suppress(Exception):  # already gone (interpreter shutdown)
                if self.p.isConnected(physicsClientId=cid):
                    self.p.disconnect(physicsClientId=cid)
        self.clients, self.client = [], None

    def _closest(self, cid, a, b):
        hits = self.p.getClosestPoints(a, b, self.threshold, physicsClientId=cid)
        if not hits:
            return np.nan, (np.nan, np.nan, np.nan)
        best = min(hits, key=lambda c: c[8])
        return best[8], tuple(-x for x in best[7])

    def answer(self):
        p = self.p
        dist = np.empty(self.n)
        normal = np.empty((self.n, 3))
        if self.formulation == "closest_points":
            for i, (cid, a, b) in enumerate(self.pairs):
                dist[i], normal[i] = self._closest(cid, a, b)
        else:
            for cid in self.clients:
                p.performCollisionDetection(physicsClientId=cid)
            for i, (cid, a, b) in enumerate(self.pairs):
                contacts = p.getContactPoints(a, b, physicsClientId=cid)
                if contacts:
                    deepest = min(contacts, key=lambda c: c[8])
                    dist[i], normal[i] = deepest[8], tuple(-x for x in deepest[7])
                else:
                    dist[i], normal[i] = self._closest(cid, a, b)
        return {"overlap": (dist <= 0).astype(float), "distance": dist, "normal": normal}

    def settings(self):
        m = self.margin
        common = {
            "integrator": {"name": "query", "order": 0},
            "collision_margin": m,
            "distance_tolerance": 2.0 * m * (math.sqrt(3.0) - 1.0),
            # GJK's closest points are the shrunk boxes' (half extents h - m) features: a
            # corner moves by up to m sqrt 3, so the line between two features (the normal of
            # a separated pair) turns as if each end moved that far
            "feature_shift": 2.0 * m * math.sqrt(3.0),
            "closest_points_threshold": self.threshold,
            "bodies": ("one GEOM_BOX shape and one multibody (mass 1, never stepped, no "
                       "gravity) per box; filter mask 0, each pair enabled by "
                       "setCollisionFilterPair"),
            "loop": ("one or two Python calls of pybullet's per-pair API per pair: the real "
                     "cost of pybullet from Python"),
            "precision": "float64 (pybullet is built with double precision)",
        }
        if self.formulation == "closest_points":
            return {**common, "algorithm": (
                "getClosestPoints for every pair (GJK, EPA when overlapping, on boxes rounded "
                "by the collision margin); distance [8], normal -[7]; overlap = distance <= 0"),
                "margin_effect": "distance larger than the boxes' by 0 to 2 m (sqrt 3 - 1)"}
        return {**common, "algorithm": (
            "performCollisionDetection once per batch, then getContactPoints per pair (the "
            "box-box detector on the full half extents): the deepest point's distance [8] and "
            "normal -[7]; pairs without contacts: getClosestPoints (GJK on boxes rounded by the "
            "collision margin); overlap = distance <= 0"),
            "depth_relative_tolerance": FUDGE_FACTOR - 1.0,
            "box_box_fudge_factor": FUDGE_FACTOR, "box_box_fudge2": FUDGE2,
            "margin_effect": ("separated pairs only: distance larger than the boxes' by 0 to "
                              "2 m (sqrt 3 - 1)")}



def _formulations(engine, scene):
    return FORMULATIONS


def _build(engine, scene, dt, integrator, formulation):
    return PybulletBoxSim(import_pybullet(), scene.part(BoxPairs), dt, formulation)


MODEL_GROUP = query_group("collision_boxes", (BoxPairs,), _build, formulations=_formulations)
