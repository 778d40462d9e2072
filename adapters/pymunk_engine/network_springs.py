"""A spring network in pymunk as point masses and `DampedSpring`s (formulations "" and
"space_damping" of the spring_network group).

Every free node is a `pymunk.Body(m, inf)` (a point mass: moment inf, so rotation cannot
matter; no shape, so nothing collides), pinned nodes are world points on the space's static
body, and each stretch edge with a free end is one `DampedSpring(L0, k, c)`; an edge between two
pinned nodes exerts nothing on a moving node and is left out.

Force law (Munk2D 2.0.1 src/cpDampedSpring.c, read): preStep, at the drifted positions, applies
the impulse (L0 - d) k h along the unit axis n from end a to end b, the in-house
-k (|d| - L0) u exactly (same units: k N/m, L0 m). Damping is NOT the in-house explicit force
-c (v_rel . u) u: each impulse pass multiplies the axis relative velocity by
exp(-c h (1/m_a + 1/m_b)) (v_coef = 1 - exp(-c h k_eff), Gauss-Seidel over `iterations`
passes, after the gravity/force kick): an implicit, exponential decay, equal to the explicit
one to O(h^2) per step. With c = 0 and no drag the step is the in-house drift-kick
(`symplectic_euler_dk`) to round-off.

Air drag -c_air v per node (scene.linear_drag):
- "" : the force -c_air v_k from the step-start velocity, written on every body in one
  `pymunk.batch` call before each step; pymunk adds h f / m in the velocity update after the
  drift: the in-house drift-kick's a(x_{k+1}, v_k) exactly.
- "space_damping" (networks of one node mass m): m v' = -c v over a step keeps
  exp(-c h / m) of v, so space.damping = exp(-c_air / m) (the fraction kept per second;
  Chipmunk raises it to the power h): exact for drag alone. It also scales the spring impulse
  applied earlier in the same step (cpBodyUpdateVelocity: v = v damping^h + h (g + f/m)), so
  the step's fixed point is the equilibrium under gravity g exp(c h / m): an O(h) shift of the
  static shape (tested exactly: tests/engines/pymunk/test_pymunk_spring_network.py).
"""
from __future__ import annotations

import math

import numpy as np

from refsim_adapters.common.spring_network import free_mask, observation
from refsim.engine import Sim

from .body_arrays import BodyArrays
from .plane import Plane
from .settings import NATIVE_STEP
from .space import ITERATIONS

SPACE_DAMPING = "space_damping"


def uniform_mass(net) -> bool:
    return bool(np.all(net.masses == net.masses[0]))


class PymunkSpringNetworkSim(Sim):
    """One Body per free node, one DampedSpring per edge with a free end."""

    def __init__(self, pymunk, scene, dt, net, formulation):
        self.scene, self.dt, self.steps, self.formulation = scene, dt, 0, formulation
        self.net = net
        self.plane = plane = Plane(3)
        self.axes = list(plane.axes)
        self.free = free_mask(net)
        self.space = space = pymunk.Space(threaded=False)
        space.iterations, space.gravity = ITERATIONS, plane.to2d(scene.gravity)
        self.drag = float(scene.linear_drag)
        space.damping = (math.exp(-self.drag / float(net.masses[0]))
                         if formulation == SPACE_DAMPING else 1.0)
        self.force_drag = self.drag if formulation != SPACE_DAMPING else 0.0
        free_nodes = np.flatnonzero(self.free)
        bodies = {}
        for node in free_nodes:  # build time: pymunk takes one body per call
            body = pymunk.Body(float(net.masses[node]), math.inf)
            body.position = plane.to2d(net.positions[node])
            body.velocity = plane.to2d(net.velocities[node])
            bodies[int(node)] = body
        space.add(*bodies.values())
        self.springs = [self._spring(pymunk, bodies, e) for e in range(len(net.edges))
                        if self.free[net.edges[e]].any()]
        space.add(*self.springs)
        self.arrays = BodyArrays(pymunk, space, len(free_nodes))

    def _spring(self, pymunk, bodies, edge):
        """DampedSpring of edge (i, j): a = node i (or the static body at its position)."""
        i, j = (int(n) for n in self.net.edges[edge])
        static = self.space.static_body
        ends = [(bodies[n], (0.0, 0.0)) if self.free[n]
                else (static, self.plane.to2d(self.net.positions[n])) for n in (i, j)]
        return pymunk.DampedSpring(ends[0][0], ends[1][0], ends[0][1], ends[1][1],
                                   float(self.net.rest_length[edge]),
                                   float(self.net.stiffness[edge]),
                                   float(self.net.damping[edge]))

    def _step_impl(self, n):
        space_step, dt = self.space.step, self.dt
        if self.force_drag > 0:
            arrays, c = self.arrays, self.force_drag
            for _ in range(n):  # pymunk has no multi-step call
                arrays.write(FORCE=-c * arrays.read("VELOCITY")["VELOCITY"])
                space_step(dt)
        else:
            for _ in range(n):
                space_step(dt)

    def _observe(self):
        got = self.arrays.read("POSITION", "VELOCITY")
        x = np.array(self.net.positions, float)
        v = np.zeros_like(x)
        free_rows = np.flatnonzero(self.free)
        x[np.ix_(free_rows, self.axes)] = got["POSITION"]
        v[np.ix_(free_rows, self.axes)] = got["VELOCITY"]
        x[free_rows, self.plane.normal_axis] = 0.0
        return observation(x, v)

    def settings(self):
        return {
            "integrator": {"name": "symplectic_euler_dk", "order": 1,
                           "family": "symplectic Euler", "explicit": True,
                           "symplectic": not self.net.damping.any() and self.drag == 0,
                           "native": NATIVE_STEP,
                           "note": "drift, spring impulses k (L0 - d) h at the drifted "
                                   "positions, gravity and drag kick, then the springs' "
                                   "damping impulse passes"},
            "formulation": self.formulation or "springs",
            "dtype": "float64", "threads": 1,
            "plane": "refsim (x, z) -> pymunk (x, y), y-up; observed y = 0",
            "space": {"iterations": self.space.iterations, "damping": self.space.damping,
                      "gravity": list(self.space.gravity), "threaded": self.space.threaded,
                      "sleeping": "off (sleep_time_threshold inf, pymunk's default)"},
            "bodies": {"count": self.arrays.count, "moment": "inf (point masses)",
                       "shapes": "none (no collision detection)",
                       "pinned": "world points on the space's static body"},
            "springs": {"type": "DampedSpring", "count": len(self.springs),
                        "force": "impulse k (L0 - d) h along the axis at the drifted "
                                 "positions (the in-house law, k N/m, L0 m)",
                        "damping": "axis relative velocity x exp(-c h (1/m_a + 1/m_b)) per "
                                   "impulse pass, after the kick (implicit, exponential; "
                                   "O(h^2) per step from the in-house explicit -c (v.u) u)",
                        "max_force": "inf (pymunk's default)"},
            "drag": self._drag_settings(),
            "observation": "pymunk.batch: every body's position and velocity in one call",
            "python_per_step": "one space.step(dt) call per step (pymunk has no multi-step "
                               "call); with force drag also one batched velocity read and "
                               "one batched force write per step",
        }

    def _drag_settings(self):
        if self.drag == 0:
            return {"c_air": 0.0, "method": "none"}
        if self.formulation == SPACE_DAMPING:
            return {"c_air": self.drag, "method": "space.damping = exp(-c_air / m): v *= "
                    "exp(-c_air h / m) in the velocity update (exact for drag alone); it also "
                    "scales the step's spring impulse, so the static shape is the one under "
                    "gravity g exp(c_air h / m) (an O(h) shift)",
                    "space_damping": self.space.damping}
        return {"c_air": self.drag, "method": "force -c_air v from the step-start velocity "
                "(pymunk.batch write before each step): the in-house drift-kick a(x1, v0)"}

    def close(self):
        self.space = self.springs = self.arrays = None
