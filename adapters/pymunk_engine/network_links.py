"""A hinge chain (hair, a rope with bending) in pymunk as rigid links: formulation
"rigid_links" of the spring_network group.

The chain is nodes 0..N joined by edges (i, i + 1), pinned nodes a prefix 0..p-1 (p >= 1: p = 2
is a clamped root), hinges at interior nodes (i - 1, i, i + 1). `DampedRotarySpring` acts on
two BODY angles, so each link (i, i + 1) with a free outer node is a rigid body; links between
two pinned nodes are the static body.
- Mass: each free node's mass is split between the links meeting there, half each (the tip's
  whole mass on the last link), placed AT the node, so the chain's mass distribution is the
  network's exactly; the link whose inner node is pinned also carries half of that pinned
  node's mass at the fixed pivot (it never moves, so it changes neither the motion nor the
  forces on free nodes; it makes the moment > 0, as pymunk requires). A link carrying a at
  its inner and b at its outer node has mass a + b, centre of gravity (a x_i + b x_o)/(a + b)
  and moment a b L^2 / (a + b).
- Joints: `PivotJoint` at every node between consecutive links (at the pinned node: to the
  static body) with pymunk's default error_bias (0.9^60: 0.18 % of a gap left after 1 s) and
  10 iterations. Measured (8 links, kb 1 N m, h 5e-4): error_bias 0 (the whole gap / h each
  step, the pivots group's choice) with 10 Gauss-Seidel passes pumps energy into the chain
  (speeds of 3 m/s that drag does not remove); it needs >= 30 passes. The default bias at 10
  passes settles to the same equilibrium (5.2e-8 m apart after 4 s, gaps 3e-14 m).
- Hinges: `DampedRotarySpring(a, b, rest, k_b, 0)`: torque (a.angle - b.angle - rest) k_b
  (Munk2D src/cpDampedRotarySpring.c), so with body angles 0 at t = 0 and the initial signed
  turn tau0 at the node (from link a's direction to link b's, counter-clockwise in pymunk's
  x-y = refsim's x-z seen from -y), rest = tau0 - tau_rest gives the energy
  1/2 k_b (tau - tau_rest)^2 with tau the signed turn. The network's rest angle theta0 in
  [0, pi] is unsigned: tau_rest = sign(tau0) theta0 (a straight start with theta0 > 0 is
  refused: the side is undetermined). For theta0 = 0 both energies are k_b tau^2 / 2.
- Links are INEXTENSIBLE: the stretch stiffness and edge damping of the network do not enter
  (damping along a rigid link is inert anyway); a stiff-spring network differs by its
  stretch, O(T / k) per link.
- Drag -c_air v on every free node: the force on each link is -c_air sum(share v_node) at the
  nodes, with its torque about the centre of gravity, from the step-start velocities, written
  in one pymunk.batch call before each step.
Observation: node positions and velocities from the link poses (x = c + R r, v = V + w perp(R r))
in numpy from one batched read.
"""
from __future__ import annotations

import math

import numpy as np

from refsim_adapters.common.spring_network import observation
from refsim.engine import Sim

from .body_arrays import BodyArrays
from .plane import Plane
from .settings import NATIVE_STEP
from .space import ITERATIONS

RIGID_LINKS = "rigid_links"
LENGTH_RTOL = 1e-12  # initial link length vs rest length: both are the same float computation
# (or a case's chosen lengths) up to a few ulps; more means the chain starts stretched, which a
# rigid link cannot represent
VELOCITY_RTOL = 1e-12  # along-link relative velocity, relative to the largest speed (same idea)


def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _perp(r):
    return np.stack([-r[..., 1], r[..., 0]], axis=-1)


def chain_layout(net):
    """(p, links' inner node indices) for a chain 0..N with pinned prefix 0..p-1, or the
    reason it is not one (a str)."""
    n = len(net)
    edges = {tuple(sorted(map(int, e))) for e in net.edges}
    if len(net.edges) != n - 1 or edges != {(i, i + 1) for i in range(n - 1)}:
        return "rigid_links needs the edges (i, i + 1) of a chain in node order, once each"
    p = len(net.pinned)
    if p == 0 or p == n or set(map(int, net.pinned)) != set(range(p)):
        return "rigid_links needs the pinned nodes to be the root prefix 0..p-1 (p >= 1)"
    middles = net.hinges[:, 1]
    ends = np.sort(net.hinges[:, [0, 2]], axis=1)
    if np.any(ends[:, 0] != middles - 1) or np.any(ends[:, 1] != middles + 1):
        return "rigid_links needs hinges (i - 1, i, i + 1) at consecutive chain nodes"
    return p, np.arange(p - 1, n - 1)


def signed_turns(x2, middles):
    """Signed turning angle at each middle node of a planar chain x2 (n, 2)."""
    e1, e2 = x2[middles] - x2[middles - 1], x2[middles + 1] - x2[middles]
    return np.arctan2(_cross(e1, e2), np.sum(e1 * e2, axis=1))


def links_reason(net) -> str | None:
    layout = chain_layout(net)
    if isinstance(layout, str):
        return f"pymunk spring networks: hinges need rigid links; {layout}"
    x2 = net.positions[:, [0, 2]]
    lengths = np.linalg.norm(np.diff(x2, axis=0), axis=1)
    rest = net.rest_length[np.argsort(np.min(net.edges, axis=1))]
    if np.any(np.abs(lengths - rest) > LENGTH_RTOL * rest):
        return "pymunk rigid_links: the chain must start at its rest lengths (links are rigid)"
    v2 = net.velocities[:, [0, 2]]
    along = np.abs(np.sum(np.diff(v2, axis=0) * np.diff(x2, axis=0), axis=1)) / lengths
    if np.any(along > VELOCITY_RTOL * max(np.abs(v2).max(), 1e-300)):
        return "pymunk rigid_links: initial velocities must not stretch a link"
    turns = signed_turns(x2, net.hinges[:, 1])
    if np.any((net.hinge_rest_angle > 0) & (turns == 0)):
        return ("pymunk rigid_links: a hinge with a rest angle > 0 starting straight has no "
                "side in the plane (pymunk's rotary spring needs a signed rest angle)")
    return None


class LinkBodies:
    """The links' masses, centres, moments and node offsets (numpy, all links at once)."""

    def __init__(self, net, x2, v2, p):
        n = len(net)
        self.inner = np.arange(p - 1, n - 1)
        outer = self.inner + 1
        m = np.asarray(net.masses, float)
        self.share_in = np.full(len(self.inner), 0.5)  # of the inner node's drag (0: pinned)
        self.share_in[0] = 0.0
        self.share_out = np.full(len(self.inner), 0.5)
        self.share_out[-1] = 1.0
        a, b = 0.5 * m[self.inner], self.share_out * m[outer]
        self.mass = a + b
        self.centre = (a[:, None] * x2[self.inner] + b[:, None] * x2[outer]) / self.mass[:, None]
        self.r_in, self.r_out = x2[self.inner] - self.centre, x2[outer] - self.centre
        self._r_in_c = self.r_in[:, 0] + 1j * self.r_in[:, 1]
        self._r_out_c = self.r_out[:, 0] + 1j * self.r_out[:, 1]
        self.moment = a * b * np.sum((x2[outer] - x2[self.inner]) ** 2, axis=1) / self.mass
        dv, dx = v2[outer] - v2[self.inner], x2[outer] - x2[self.inner]
        self.omega = _cross(dx, dv) / np.sum(dx * dx, axis=1)
        self.velocity = (a[:, None] * v2[self.inner] + b[:, None] * v2[outer]) / self.mass[:, None]

    def nodes(self, pos, angle, vel, omega):
        """Outer nodes' positions and velocities from the link poses."""
        c, s = np.cos(angle), np.sin(angle)
        rx = c * self.r_out[:, 0] - s * self.r_out[:, 1]
        ry = s * self.r_out[:, 0] + c * self.r_out[:, 1]
        r = np.stack([rx, ry], axis=1)
        return pos + r, vel + omega[:, None] * _perp(r)

    def drag_loads(self, pos, angle, vel, omega, c_air):
        """(force (k, 2), torque (k,)) of -c_air v at each link's nodes, by share. Plane
        vectors as complex numbers: R r = exp(i angle) r, w perp(r) = i w r,
        cross(r, f) = Im(conj(r) f)."""
        turn = np.exp(1j * angle)
        r_in, r_out = turn * self._r_in_c, turn * self._r_out_c
        v_c = vel[:, 0] + 1j * vel[:, 1]
        spin = 1j * omega
        f_in = -c_air * self.share_in * (v_c + spin * r_in)
        f_out = -c_air * self.share_out * (v_c + spin * r_out)
        force = f_in + f_out
        torque = (np.conj(r_in) * f_in + np.conj(r_out) * f_out).imag
        return np.stack([force.real, force.imag], axis=1), torque


class PymunkLinkChainSim(Sim):
    """One Body per moving link, PivotJoints at the nodes, DampedRotarySprings at hinges."""

    def __init__(self, pymunk, scene, dt, net):
        self.scene, self.dt, self.steps = scene, dt, 0
        self.net = net
        self.plane = plane = Plane(3)
        self.axes = list(plane.axes)
        self.p, _ = chain_layout(net)
        x2 = net.positions[:, self.axes]
        v2 = np.array(net.velocities[:, self.axes])
        v2[: self.p] = 0.0
        self.links = links = LinkBodies(net, x2, v2, self.p)
        self.drag = float(scene.linear_drag)
        self.space = space = pymunk.Space(threaded=False)
        space.iterations, space.damping = ITERATIONS, 1.0
        space.gravity = plane.to2d(scene.gravity)
        self.bodies = []
        for k in range(len(links.mass)):  # build time: pymunk takes one body per call
            body = pymunk.Body(float(links.mass[k]), float(links.moment[k]))
            body.position, body.velocity = tuple(links.centre[k]), tuple(links.velocity[k])
            body.angular_velocity = float(links.omega[k])
            self.bodies.append(body)
        space.add(*self.bodies)
        self.pivots = [self._pivot(pymunk, k, x2) for k in range(len(self.bodies))]
        self.hinges = self._rotary_springs(pymunk, x2)
        space.add(*self.pivots, *(h for h, _ in self.hinges))
        self.arrays = BodyArrays(pymunk, space, len(self.bodies))

    def _pivot(self, pymunk, k, x2):
        links, body = self.links, self.bodies[k]
        if k == 0:  # at the last pinned node: the static body (at the origin, local = world)
            joint = pymunk.PivotJoint(self.space.static_body, body,
                                      tuple(x2[links.inner[0]]), tuple(links.r_in[0]))
        else:
            joint = pymunk.PivotJoint(self.bodies[k - 1], body, tuple(links.r_out[k - 1]),
                                      tuple(links.r_in[k]))
        return joint  # pymunk's default error_bias and max_bias (see the module doc)

    def _rotary_springs(self, pymunk, x2):
        """[(DampedRotarySpring, tau_rest)] for hinges with a moving link beside them."""
        net, out = self.net, []
        middles = net.hinges[:, 1]
        turns = signed_turns(x2, middles)
        for h, node in enumerate(middles):  # build time: one constraint per call
            if node < self.p - 1:
                continue  # both links static: no force on anything that moves
            b = self.bodies[node - (self.p - 1)]
            a = self.space.static_body if node == self.p - 1 else self.bodies[node - self.p]
            tau_rest = math.copysign(float(net.hinge_rest_angle[h]), turns[h])
            spring = pymunk.DampedRotarySpring(a, b, float(turns[h] - tau_rest),
                                               float(net.hinge_stiffness[h]), 0.0)
            out.append((spring, tau_rest))
        return out

    def _poses(self):
        got = self.arrays.read("POSITION", "ANGLE", "VELOCITY", "ANGULAR_VELOCITY")
        return (got["POSITION"], got["ANGLE"][:, 0], got["VELOCITY"],
                got["ANGULAR_VELOCITY"][:, 0])

    def _step_impl(self, n):
        space_step, dt = self.space.step, self.dt
        if self.drag > 0:
            for _ in range(n):  # pymunk has no multi-step call
                force, torque = self.links.drag_loads(*self._poses(), self.drag)
                self.arrays.write(FORCE=force, TORQUE=torque)
                space_step(dt)
        else:
            for _ in range(n):
                space_step(dt)

    def _observe(self):
        x_out, v_out = self.links.nodes(*self._poses())
        x = np.array(self.net.positions, float)
        v = np.zeros_like(x)
        x[np.ix_(np.arange(self.p, len(x)), self.axes)] = x_out
        v[np.ix_(np.arange(self.p, len(x)), self.axes)] = v_out
        return observation(x, v)

    def link_gaps(self) -> np.ndarray:
        """|outer node of link k - inner node of link k + 1| and the root pivot's gap (m)."""
        pos, angle, vel, omega = self._poses()
        ends, _ = self.links.nodes(pos, angle, vel, omega)
        c, s = np.cos(angle), np.sin(angle)
        r = self.links.r_in
        starts = pos + np.stack([c * r[:, 0] - s * r[:, 1], s * r[:, 0] + c * r[:, 1]], 1)
        root = self.net.positions[self.p - 1, self.axes]
        return np.linalg.norm(np.vstack([starts[:1] - root, starts[1:] - ends[:-1]]), axis=1)

    def settings(self):
        links = self.links
        return {
            "integrator": {"name": "symplectic_euler_dk", "order": 1,
                           "family": "symplectic Euler", "explicit": True, "symplectic": False,
                           "native": NATIVE_STEP,
                           "note": "maximal coordinates: drift, rotary-spring impulses, "
                                   "gravity and drag kick, then PivotJoint impulse passes "
                                   "with pymunk's default bias (dissipative), not a "
                                   "symplectic map"},
            "formulation": RIGID_LINKS, "dtype": "float64", "threads": 1,
            "plane": "refsim (x, z) -> pymunk (x, y), y-up; observed y = 0",
            "space": {"iterations": self.space.iterations, "damping": self.space.damping,
                      "gravity": list(self.space.gravity), "threaded": self.space.threaded},
            "links": {"count": len(self.bodies), "inextensible": True,
                      "mass": links.mass.tolist(), "moment": links.moment.tolist(),
                      "mass_split": "half of each free node's mass on each link meeting there "
                                    "(the tip's whole mass on the last), at the node; half "
                                    "the pinned root node's mass at the fixed pivot",
                      "stretch": "ignored: links are rigid (stretch stiffness and edge "
                                 "damping do not enter)", "shapes": "none"},
            "pivots": {"type": "PivotJoint", "count": len(self.pivots),
                       "error_bias": [j.error_bias for j in self.pivots],
                       "bias_coef_per_step": [1.0 - j.error_bias ** self.dt
                                              for j in self.pivots],
                       "bias_choice": "pymunk's default kept: error_bias 0 with 10 passes "
                                      "pumped energy into an 8-link chain (measured)",
                       "max_bias": str(self.pivots[0].max_bias),
                       "max_force": str(self.pivots[0].max_force)},
            "hinges": {"type": "DampedRotarySpring", "count": len(self.hinges),
                       "stiffness": [s.stiffness for s, _ in self.hinges],
                       "rest_turn": [t for _, t in self.hinges],
                       "rest_angle_pymunk": [s.rest_angle for s, _ in self.hinges],
                       "damping": 0.0,
                       "law": "torque (tau_rest - tau) k_b on the outer link, tau the signed "
                              "turn; the network's unsigned rest angle takes the initial "
                              "turn's sign"},
            "drag": {"c_air": self.drag,
                     "method": "force -c_air v at each node by mass share, with its torque, "
                               "from the step-start velocities (pymunk.batch write)"},
            "observation": "pymunk.batch: every link's pose in one call; nodes in numpy",
            "python_per_step": "one space.step(dt) call per step; with drag one batched "
                               "read and one batched write per step",
        }

    def close(self):
        self.space = self.bodies = self.pivots = self.hinges = self.arrays = None
