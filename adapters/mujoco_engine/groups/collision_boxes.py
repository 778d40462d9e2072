"""MuJoCo answers box-pair queries (issue 28, BoxPairs): `mj_geomDistance` per pair.

Model: one MjModel of 2C box geoms on the world body (C = min(n, CHUNK) pairs; geoms 2j and
2j+1 are pair j of the chunk), no bodies, no joints. The batch goes through it in chunks of C
pairs: each chunk's half extents are copied into `m.geom_size` and its poses straight into
`d.geom_xpos` / `d.geom_xmat` (three vectorised copies per chunk), then one
`mj_geomDistance(m, d, 2j, 2j+1, distmax, fromto)` per pair from Python: that Python call per
pair is MuJoCo's real cost from Python (it has no batch distance call). mj_geomDistance reads
only `geom_size`, `geom_xpos` and `geom_xmat` (engine_support.c, engine_collision_convex.c
mjc_initCCDObj, engine_collision_box.c mjc_BoxBox), so no mj_kinematics runs: the rotations
reach MuJoCo as the case's matrices, not rounded through quaternions. A model holding all 2n
boxes would save the copies but its compile time grows faster than n (measured 0.03 s for
2000 geoms, 1.3 s for 20000) and 10^5 pairs would not compile in a reasonable setup: hence
chunks. Geoms on one body never collide with each other and mj_collision is not called on
this model: no contact exclusion is needed.

Answers (refsim/scene/queries.py): distance = mj_geomDistance's signed value (distmax = the
largest centre distance of the batch plus 1 m, above every pair's distance; where MuJoCo finds
nothing within distmax it returns distmax, kept as its answer, normal NaN); normal =
sign(distance) (to - from) / |to - from|, from A towards B for both signs (checked on closed
forms: tests/engines/mujoco/test_mujoco_collision.py); normalised, since to - from carries the
witness points' round-off (eps x their coordinates) relative to |distance|: unnormalised, its
length was 1 +- 1e-12 on millimetre depths 10 m from the origin, an arccos angle of 1e-4 deg.
overlap = distance < 0. Where from = to or the distance is 0 (touching) the normal is the
contact frame's first axis of `mj_collision` on a second model of two free boxes (MuJoCo's
contact normal points from geom1 to geom2), NaN where that finds no contact.

Formulations (docs/engine_notes.md#mujoco-box-pair-distance-routines):
- "" (nativeccd, MuJoCo's default): mj_geomDistance calls mjc_ccd: GJK for the distance, EPA
  for the penetration. For two boxes ("discrete geoms") GJK and EPA run to their own exact
  stops (tolerance 0 and mjMINVAL in engine_collision_gjk.c), so ccd_tolerance and
  ccd_iterations do not change the answers of separated or clearly overlapping pairs
  (measured: 1e-6 -> 1e-12 and 35 -> 1000 alter nothing on 4000 random pairs; errors
  <= 3.6e-15 m). Two exceptions, measured on mujoco 4.0.0: (1) a separated pair closer than
  min(ccd_tolerance, ~3e-8 m) may be taken as touching and answered 0 or -gap (a false
  positive; 7 % of random pairs at a 1e-8 m gap, none at 1e-6 m; ccd_tolerance 1e-12 removes
  it): the declared "distance_tolerance" is 2 ccd_tolerance; (2) EPA returns a wrong
  penetration on about 1 overlapping pair in 1000 (10 m from the origin: depth 0.218 m for
  0.264 m, normal 8.8 deg off; moving the pair to the origin changes it), nothing declared
  excuses it.
- "nativeccd_off" (`<flag nativeccd="disable"/>`): for two boxes mj_geomDistance then calls the
  dedicated box-box collider mjc_BoxBox with distmax as its margin, and takes its deepest
  contact; libccd's MPR is never reached for box pairs (it serves the mjc_Convex pairs). That
  collider is a separating-axis test with face clipping made for contact manifolds, not
  distances: where the nearest features of separated boxes lie off the faces' overlap it
  returns no contact and mj_geomDistance answers distmax (18 % of random separated pairs; a
  corner-to-corner gap of 2.598 m answered distmax), and 42 % of the others get the distance
  of the clipped contact points, not the gap (off by up to 0.73 m); penetrations prefer a face
  axis over an edge axis within 5 % of the depth (ODE's rule, in the collider's comments):
  depths up to 0.9 % too deep, normals up to 7.9 deg off (8 % of overlapping pairs). The
  declared "distance_tolerance" is 0: nothing excuses these.
"""
from __future__ import annotations

import numpy as np

from refsim.query import QuerySim, query_group
from refsim.scene.queries import BoxPairs

CHUNK = 512  # pairs per model chunk (1024 geoms: compiles in ~0.02 s)
FORMULATIONS = {
    "": "nativeccd (MuJoCo's default): mj_geomDistance -> mjc_ccd, GJK distance, EPA "
        "penetration",
    "nativeccd_off": "flag nativeccd disabled: mj_geomDistance -> mjc_BoxBox (the dedicated "
                     "separating-axis box-box collider, distmax as margin); libccd MPR is not "
                     "used for box pairs",
}
ROUTINES = {
    "": "mj_geomDistance -> mj_geomDistanceCCD -> mjc_ccd (nativeccd GJK, EPA when the GJK "
        "distance is <= ccd_tolerance)",
    "nativeccd_off": "mj_geomDistance -> mjc_BoxBox(margin = distmax), least contact dist; "
                     "distmax where it returns no contact",
}


def _flag(formulation: str, extra: str = "") -> str:
    native = ' nativeccd="disable"' if formulation == "nativeccd_off" else ""
    return f"<flag{native}{extra}/>" if native or extra else ""


def chunk_xml(pairs: int, formulation: str) -> str:
    geoms = '<geom type="box" size="1 1 1"/>' * (2 * pairs)
    return (f'<mujoco model="refsim_box_pairs"><option>{_flag(formulation)}</option>'
            f'<worldbody>{geoms}</worldbody></mujoco>')


def touch_xml(formulation: str) -> str:
    bodies = "".join(f'<body name="{s}"><freejoint/><geom type="box" size="1 1 1"/></body>'
                     for s in "ab")
    flags = _flag(formulation, ' gravity="disable"')
    return (f'<mujoco model="refsim_box_touch"><option>{flags}</option>'
            f'<worldbody>{bodies}</worldbody></mujoco>')


class MujocoBoxPairsSim(QuerySim):
    names = ("overlap", "distance", "normal")

    def __init__(self, part: BoxPairs, dt: float, formulation: str):
        import mujoco
        super().__init__(dt)
        self.mj, self.formulation = mujoco, formulation
        n = self.n = len(part)
        # pair i -> rows 2i (A), 2i+1 (B), as the chunk model's geoms
        self.size = np.stack([part.a_half, part.b_half], 1).reshape(2 * n, 3).copy()
        self.pos = np.stack([part.a_center, part.b_center], 1).reshape(2 * n, 3).copy()
        self.mat = np.stack([part.a_rotation, part.b_rotation], 1).reshape(2 * n, 9).copy()
        gap = np.linalg.norm(part.b_center - part.a_center, axis=1)
        self.distmax = float(gap.max(initial=0.0)) + 1.0  # 1 m above every |d| <= gap
        self.pairs = max(1, min(n, CHUNK))
        self.model = mujoco.MjModel.from_xml_string(chunk_xml(self.pairs, formulation))
        self.data = mujoco.MjData(self.model)
        self._fromto = np.zeros((self.pairs, 6))
        self._views = list(self._fromto)  # one fromto row per pair slot, made once
        self._touch = None  # the two-free-box model for exact touches, made when needed

    # -- the batch --------------------------------------------------------------------------------
    def answer(self):
        n, c = self.n, self.pairs
        dist, fromto = np.empty(n), np.empty((n, 6))
        gd, m, d, dmax, views = self.mj.mj_geomDistance, self.model, self.data, self.distmax, \
            self._views
        for s in range(0, n, c):
            k = min(c, n - s)
            rows = slice(2 * s, 2 * (s + k))
            m.geom_size[:2 * k] = self.size[rows]
            d.geom_xpos[:2 * k] = self.pos[rows]
            d.geom_xmat[:2 * k] = self.mat[rows]
            # one mj_geomDistance per pair from Python (MuJoCo has no batch distance call)
            dist[s:s + k] = [gd(m, d, 2 * j, 2 * j + 1, dmax, views[j]) for j in range(k)]
            fromto[s:s + k] = self._fromto[:k]
        seg = fromto[:, 3:] - fromto[:, :3]  # from A's witness point to B's
        length = np.linalg.norm(seg, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            normal = seg * (np.sign(dist) / length)[:, None]  # unit, A towards B
        normal[dist >= self.distmax] = np.nan  # no contact found within distmax: no normal
        touching = np.flatnonzero(((length == 0.0) | (dist == 0.0)) & (dist < self.distmax))
        if len(touching):
            normal[touching] = [self._contact_normal(i) for i in touching]
        return {"overlap": (dist < 0).astype(float), "distance": dist, "normal": normal}

    def _contact_normal(self, i: int) -> np.ndarray:
        """mj_collision's contact normal (geom1 -> geom2) for pair i on two free boxes."""
        mj = self.mj
        if self._touch is None:
            model = mj.MjModel.from_xml_string(touch_xml(self.formulation))
            self._touch = (model, mj.MjData(model))
        m, d = self._touch
        for g in range(2):
            row = 2 * i + g
            quat = np.zeros(4)
            mj.mju_mat2Quat(quat, self.mat[row])
            d.qpos[7 * g:7 * g + 7] = [*self.pos[row], *quat]
            m.geom_size[g] = self.size[row]
            m.geom_rbound[g] = np.linalg.norm(self.size[row])  # the broad phase's sphere
        mj.mj_kinematics(m, d)
        mj.mj_collision(m, d)
        if d.ncon == 0:
            return np.full(3, np.nan)
        best = int(np.argmin(d.contact.dist[:d.ncon]))
        sign = 1.0 if d.contact.geom[best][0] == 0 else -1.0
        return sign * d.contact.frame[best][:3]

    def settings(self):
        opt = self.model.opt
        native = self.formulation == ""
        return {
            "integrator": {"name": "query", "order": 0},
            "formulation": FORMULATIONS[self.formulation],
            "routine": ROUTINES[self.formulation],
            "nativeccd": "enabled" if native else "disabled",
            "ccd_tolerance": float(opt.ccd_tolerance),
            "ccd_iterations": int(opt.ccd_iterations),
            # a separated pair within ccd_tolerance may be answered 0 or -gap (docstring)
            "distance_tolerance": 2.0 * float(opt.ccd_tolerance) if native else 0.0,
            "distmax": self.distmax,
            "precision": "float64",
            "python_per_query": "one mj_geomDistance call per pair from Python (no batch "
                                "call): MuJoCo's real cost from Python",
            "model": f"{2 * self.pairs} box geoms on the world body, the batch in chunks of "
                     f"{self.pairs} pairs: half extents copied into m.geom_size, poses into "
                     "d.geom_xpos / d.geom_xmat (no mj_kinematics, no quaternions)",
            "normal": "sign(distance) (to - from) / |to - from| from mj_geomDistance's fromto "
                      "(A towards B, both signs); where from = to or distance 0 mj_collision's "
                      "contact frame",
            "geom_margin": 0.0,
        }



def _build(engine, scene, dt, integrator, formulation):
    if formulation not in FORMULATIONS:
        raise ValueError(f"mujoco collision_boxes formulation must be one of "
                         f"{list(FORMULATIONS)}, got {formulation!r}")
    return MujocoBoxPairsSim(scene.part(BoxPairs), dt, formulation)


MODEL_GROUP = query_group(
    "collision_boxes", (BoxPairs,), _build, formulations=lambda engine, scene: tuple(FORMULATIONS))
