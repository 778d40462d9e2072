"""A static equilibrium from pybullet's own deformable step: staged damped dynamics.

Each stage loads the body afresh at the previous stage's positions, at rest (pybullet cannot
reset node velocities), with fixedTimeStep h and NeoHookeanDamping b = R h (s), and steps until
it settles. Why this works and why in stages (fem_softbody.py has the step):
- with b = h, a linear mode of angular frequency w contracts by 1 / sqrt(1 + (h w)^2) per step
  (symplectic Euler with the stiffness-proportional damping solved by backward Euler); for
  h w >> 1 the step is the fixed-point iteration x += (h / b) K_d^-1 f(x), K_d the damping's
  rest stiffness. The first stage takes h_0 = C_SLOWEST / w_min: the slowest mode contracts by
  1/sqrt(10) a step.
- the damping solve skips any velocity change under 1e-8 m/s, so at a static error e the kick
  h K e / m goes undamped once it is below that: a stage settles to an error floor of about
  1e-8 m/s / (h w_min^2). A larger h lowers it, so h grows RAMP-fold per stage; measured on the
  tetrahedral patch test: h = 0.015, 0.15, 1.5, 15 s left errors of 2e-11, 7e-13, 2e-13,
  1e-14 m.
- a large h hits the velocity clamp |v| <= diagonal / h while the forces are large (h = 0.3 s
  from the start crawled at 3e-3 m per step there), so every h is capped at the clamp-safe
  step sqrt(diagonal / (CLAMP_MARGIN max|a|)), a the accelerations at the stage's start.
- a stage whose moves stop halving before they settle (or blow up) restarts from its start:
  first with R = RETRY, then with h / RETRY and R = 1, h capped there from then on. Far from
  the rest shape (large rotations) K_d no longer bounds the tangent stiffness and b = h can
  oscillate (a 1 m bar sagging 0.28 m under gravity did at h = 1.6 s): under-relaxation
  x += K_d^-1 f / R settles it. On finer meshes the damping solve (M + h b K_d) dv = r needs
  more than its 300 iterations once h b w_max^2 is large, the stiff modes go undamped and the
  explicit step blows up (a 1152-tetrahedron bar at h = b = 0.97 s; each step then costs
  ~30 us per tetrahedron): a smaller h settles it, and the floor stays higher.
A stage ends once its largest node move per step has not halved in STALL_HALVINGS x the steps
the slowest linear mode needs to halve (`halving_steps`), with the move below h x 1e-8 m/s,
and its positions, reloaded at rest, move at most VERIFY x h x 1e-8 m/s in one step.
The solve ends when the floor is within ROUND_OFF x max|x|, when the clamp keeps h from growing
past the last settled stage's, or when a settled stage's smallest move exceeds the smallest so
far (a larger h then only amplifies the forces' rounding, by (h w)^2); it returns the
positions of the smallest move of all settled stages. w_min and the accelerations come from refsim's model of
the same law (its forces equal pybullet's: tested); they choose the steps; the positions are
pybullet's.
"""
from __future__ import annotations

import math

import numpy as np
import scipy.linalg
import scipy.sparse.linalg

from refsim.engine import EngineFailure
from refsim.models.fem.assembly import Assembler
from refsim.models.fem.model import ElasticBody

from .fem_softbody import CR_TOLERANCE, load_mesh, node_masses
from .softbody import node_positions

C_SLOWEST = 3.0  # h w_min of the first stage: the slowest mode contracts by 1/sqrt(10) a step
RAMP = 100.0  # h and b grow a hundredfold from stage to stage (tenfold: 1.5-2x the stages)
RETRY = 10.0  # a stage that does not settle restarts with b = RETRY h, then with h / RETRY
MAX_STAGES = 14  # stages (restarts included) per solve
CLAMP_MARGIN = 4.0  # h^2 max|a| <= diagonal / CLAMP_MARGIN: clear of the velocity clamp
STALL_HALVINGS = 8.0  # a stage ends (or restarts) when its move has not halved in this many
#                       times the steps the slowest linear mode needs to halve (at least
#                       STALL_MIN): 8, as the tangent stiffness far from rest can be a few
#                       times softer than the damping's rest stiffness
STALL_MIN = 20
CLAMP_CHECK = 20  # steps between checks whether a clamp-held stage may restart with a larger h
VERIFY = 10.0  # a settled stage's positions, reloaded at rest, may move VERIFY x h x 1e-8 m/s
#                in one step (pybullet's damping solve can stall at its 300 iterations and
#                leave a near-still state far from equilibrium: a 1152-tetrahedron bar once
#                "settled" 2.5e-4 m away; its runs are not repeatable there)
MAX_TET_STEPS = 2e6  # pybullet steps x tetrahedra per solve, all stages together (then a
#                      failure): 16,000 steps of the 120-tetrahedron bar; a damped step costs
#                      up to ~30 us per tetrahedron (300 conjugate-residual iterations)
ROUND_OFF = 64 * np.finfo(float).eps  # x max|x|: a floor this small is below the forces'
#                                       rounding through the stiffness (64 eps lambda_max |x|
#                                       / lambda_min, cases/fem/_static.py)
DENSE_DOFS = 300  # free dofs up to which the lowest eigenvalue is found densely (3000:
#                   18.7 s dense, 0.5 s by shift-invert Lanczos)


DESCRIPTION = (
    "damped dynamics in pybullet's own deformable step, in stages: each loads the body at the "
    "previous stage's positions at rest with fixedTimeStep h and NeoHookeanDamping b = R h "
    f"(R = 1 at first); h_0 = min({C_SLOWEST:g} / w_min, clamp-safe step), h x {RAMP:g} per "
    f"stage, capped at the clamp-safe step sqrt(diagonal / ({CLAMP_MARGIN:g} max|a|)); a stage "
    f"ends when its largest node move per step has not halved in {STALL_HALVINGS:g} x the "
    "steps the slowest linear mode needs to halve, with the move below h x 1e-8 m/s (the "
    f"damping solve's tolerance) and the positions, reloaded at rest, moving at most "
    f"{VERIFY:g} x h x 1e-8 m/s in one step, else it restarts from its start with R = {RETRY:g}, then "
    f"with h / {RETRY:g} and R = 1 (h capped there); the solve "
    "ends when the floor 1e-8 m/s / (h w_min^2) is within "
    f"{ROUND_OFF:.3g} x max|x|, when the clamp stops h from growing, when a stage's smallest "
    f"move exceeds the smallest so far, after {MAX_STAGES} stages, or (failure) "
    f"{MAX_TET_STEPS:g} steps x tetrahedra "
    "without a settled stage; the positions kept: those of the smallest move of all settled "
    "stages (adapters/pybullet_engine/fem_relax.py)")


class Unsettled(Exception):
    def __init__(self, steps, move):
        super().__init__(f"unsettled after {steps} steps (move {move:.3g} m)")
        self.steps, self.move = steps, move


def lowest_frequency(mesh) -> float:
    """w_min (rad/s) of the free nodes about the rest shape: refsim's tangent stiffness of the
    mesh's law at rest over pybullet's (equal) node mass."""
    body = ElasticBody.of(mesh)
    k = Assembler(body).stiffness(body.to_local(mesh.vertices)).tocsr()
    free = np.ones((len(mesh), 3), bool)
    free[mesh.pinned] = False
    kff = k[free.ravel()][:, free.ravel()]
    if kff.shape[0] <= DENSE_DOFS:
        lowest = scipy.linalg.eigvalsh(kff.toarray(), subset_by_index=(0, 0))[0]
    else:
        lowest = scipy.sparse.linalg.eigsh(kff.tocsc(), k=1, sigma=0.0,
                                           return_eigenvectors=False)[0]
    if not lowest > 0:
        raise EngineFailure("pybullet fem steady: the pinned nodes leave the mesh free to move "
                            "rigidly (no static equilibrium)")
    return float(np.sqrt(lowest / node_masses(mesh).max()))


class Relaxation:
    """The staged solve of one mesh in one pybullet client (`p`, `cid`) under `gravity`."""

    def __init__(self, p, cid, mesh, tet_file, gravity):
        self.p, self.cid, self.mesh, self.tet_file = p, cid, mesh, tet_file
        self.gravity = np.asarray(gravity, float)
        self.w_min = lowest_frequency(mesh)
        self.model = ElasticBody.of(mesh)
        self.free = np.ones(len(mesh), bool)
        self.free[mesh.pinned] = False
        self.masses = node_masses(mesh)[self.free, None]

    def clamp_safe_step(self, x) -> float:
        """The largest h with h^2 max|a| <= diagonal / CLAMP_MARGIN at positions x, at rest."""
        accel = self.model.forces(x)[self.free] / self.masses + self.gravity
        largest = float(np.linalg.norm(accel, axis=1).max())
        diagonal = float(np.linalg.norm(np.ptp(x, axis=0)))
        return np.inf if largest == 0 else float(np.sqrt(diagonal / (CLAMP_MARGIN * largest)))

    def halving_steps(self, h, ratio) -> float:
        """Steps in which the slowest linear mode (w_min) halves its error with step h and
        damping b = ratio x h: 2 ln 2 / (ratio (h w)^2) while the damping per step is small
        (c = b h w^2 << 1), ln 2 x ratio once it dominates (each step then moves x by 1/ratio
        of the way, x += (h / b) K_d^-1 f)."""
        c = ratio * (h * self.w_min) ** 2
        return math.log(2.0) * max(ratio, 2.0 / c)

    def stage(self, x, h, ratio, budget, target):
        """One stage from x at rest with step h and damping b = ratio x h: (positions where the
        largest node move per step was smallest, that move, steps, settled). It settles once
        that move has not halved in `window` steps (its floor) while below h x CR_TOLERANCE
        (the damping solve's tolerance, as a velocity). A stage whose h the clamp held below
        `target` ends unsettled (returns at once) as soon as the clamp-safe step at its
        positions reaches min(target, RAMP h) (checked every CLAMP_CHECK steps). Unsettled
        (raised) when it stops halving above that velocity, a move passes the body's diagonal
        or is not finite, or the step budget runs out."""
        p, cid = self.p, self.cid
        body = load_mesh(p, cid, self.mesh, self.tet_file, ratio * h, self.gravity, x)
        p.setPhysicsEngineParameter(fixedTimeStep=h, numSubSteps=0, physicsClientId=cid)
        window = max(STALL_MIN, math.ceil(STALL_HALVINGS * self.halving_steps(h, ratio)))
        best, kept, steps, mark, accelerating = np.inf, x, 0, (0.0, 0), True
        while True:
            p.stepSimulation(physicsClientId=cid)
            steps += 1
            new = node_positions(p, cid, body)
            move = float(np.abs(new - x).max())
            x = new
            if move < best:
                best, kept = move, x
            accelerating = accelerating and move > mark[0]
            if steps == 1 or accelerating or move < 0.5 * mark[0]:
                mark = (move, steps)  # still gathering speed from rest, or halved
            if not move <= np.linalg.norm(np.ptp(x, axis=0)) or steps >= budget:
                raise Unsettled(steps, move)
            if steps - mark[1] >= window:
                if move > h * CR_TOLERANCE:
                    raise Unsettled(steps, move)
                self.verify(kept, h, ratio, steps)
                return kept, best, steps + 1, True  # the verifying step counted
            if h < target and steps % CLAMP_CHECK == 0 and \
                    self.clamp_safe_step(x) >= min(target, RAMP * h):
                return x, move, steps, False

    def verify(self, x, h, ratio, steps):
        """Unsettled unless the body, loaded at x at rest, moves at most VERIFY x h x
        CR_TOLERANCE in one step: an equilibrium within the stage's floor kicks its nodes by
        about the damping solve's tolerance; a state off it by e moves by about e."""
        body = load_mesh(self.p, self.cid, self.mesh, self.tet_file, ratio * h, self.gravity, x)
        self.p.setPhysicsEngineParameter(fixedTimeStep=h, numSubSteps=0, physicsClientId=self.cid)
        self.p.stepSimulation(physicsClientId=self.cid)
        move = float(np.abs(node_positions(self.p, self.cid, body) - x).max())
        if not move <= VERIFY * h * CR_TOLERANCE:
            raise Unsettled(steps + 1, move)

    def solve(self, x):
        """(positions, pybullet steps, stage log, the error floor of the stage kept)."""
        x, total, log, floor = np.array(x, float), 0, [], np.inf
        target, ratio, settled_h, kept = C_SLOWEST / self.w_min, 1.0, 0.0, (np.inf, None)
        cap, budget = np.inf, int(MAX_TET_STEPS / len(self.mesh.tetrahedra))
        while len(log) < MAX_STAGES:
            target = min(target, cap)
            h = min(target, self.clamp_safe_step(x))
            try:
                x_new, move, steps, settled = self.stage(x, h, ratio, budget - total, target)
            except Unsettled as exc:  # from the stage's start again, as below
                total += exc.steps
                log.append({"h_s": h, "damping_s": ratio * h, "steps": exc.steps,
                            "unsettled_move_m": exc.move})
                if total >= budget:
                    break
                if ratio == 1.0:  # under-relaxed: b = RETRY h (large rotations)
                    ratio, target = RETRY, h
                else:  # a smaller step, and never this one again (the damping solve's
                    ratio, target, cap = 1.0, h / RETRY, h / RETRY  # 300 iterations fall short)
                continue
            x, total = x_new, total + steps
            entry = {"h_s": h, "damping_s": ratio * h, "steps": steps, "move_m": move}
            if not settled:  # the clamp let h grow: go on from here with a larger one
                log.append({**entry, "ended": "clamp-safe step grew"})
                continue
            log.append({**entry, "floor_m": CR_TOLERANCE / (h * self.w_min ** 2)})
            if move > kept[0]:  # a larger h only amplified the forces' rounding: stop
                break
            kept, floor = (move, x), log[-1]["floor_m"]
            if floor <= ROUND_OFF * np.abs(x).max() or h <= settled_h or cap <= h:
                break  # at round-off, or the clamp or the cap keeps h from growing
            settled_h, target = h, h * RAMP
        if kept[1] is None:
            raise EngineFailure(f"pybullet fem steady: no stage settled in {total} steps: {log}")
        return kept[1], total, log, floor
