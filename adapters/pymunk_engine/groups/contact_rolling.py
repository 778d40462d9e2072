"""pymunk's rolling group: rigid bodies with collision shapes (`RigidShapes`) on walls, with
friction: a disc rolling or slipping on an incline, in pymunk's plane (the scene's x-z plane).

Module named so that it sorts before any `rigid` group (discover_groups takes the first group
that claims a scene). Each body is a `pymunk.Body(mass, moment)` with the moment = the scene's
inertia about the plane's normal (world y; the shape's axis, checked along it), carrying a
`Circle` of the shape's radius (a cylinder seen edge-on and a sphere's great circle are the same
circle in the plane); each wall a static `Segment` (radius 0) along the wall's line, spanning
WALL_HALF_LENGTH around its point. Chipmunk multiplies the two shapes' friction and elasticity
per contact (cpArbiterUpdate): each shape gets sqrt(mu) (adapters.common.contacts), elasticity 0.
Contact position correction off (space.collision_bias = 1, slop 0: the sphere adapter's
setting), so positions move only with the velocities; 10 iterations (the default:
docs/engine_notes.md#pymunk-space-defaults).
Step (cpSpaceStep): positions and angles drift with the old velocities, then gravity kicks the
velocities and the contact impulses (normal, then Coulomb friction clamped to mu times the
normal impulse) project them: drift-kick, first order, s_k = a h^2 k (k - 1) / 2.
Observables: x, v (plane axes, y = 0), q = exp(angle/2 about y) (x) q0, w (world, along y),
orientation_defect 0 (an angle has none).
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup, Sim
from refsim.scene import RigidBodies, Walls
from refsim.scene.rigid_shapes import RigidShapes, rolling_scene_refusal

from ...common.contacts import per_shape_coefficients
from ..plane import Plane
from ..space import COLLISION_BIAS, COLLISION_SLOP, ITERATIONS

WHO = "pymunk adapter"
WALL_HALF_LENGTH = 1e3  # m: a segment this long each side of the wall point (pymunk has no
# half-plane); a body must travel 1 km along the wall to fall off its end


def claims(scene) -> bool:
    return scene.part(RigidBodies) is not None and scene.part(RigidShapes) is not None


def supports(engine, scene, integrator):
    if scene.dim != 3:
        return f"{WHO}: the rolling group takes 3D scenes moving in their x-z plane"
    return rolling_scene_refusal(scene, WHO)


def build(engine, scene, dt, integrator, formulation):
    import pymunk
    return PymunkRollingSim(pymunk, scene, dt)


MODEL_GROUP = ModelGroup(
    name="rolling", build=build, claims=claims,
    parts=frozenset({"rigid", "rigid_shapes", "walls"}),
    features=frozenset({"rigid", "shapes", "walls", "contacts", "gravity"}), supports=supports,
    formulations=lambda engine, scene: ("",), integrators=("symplectic_euler_dk",))


class PymunkRollingSim(Sim):
    """One Body + Circle per rigid body, one static Segment per wall; space.step(dt)."""

    def __init__(self, pymunk, scene, dt):
        self.scene, self.dt, self.steps = scene, dt, 0
        self.plane = plane = Plane(scene.dim)
        self.rigid = rigid = scene.part(RigidBodies)
        shapes, walls = scene.part(RigidShapes), scene.part(Walls)
        self.space = space = pymunk.Space(threaded=False)
        space.iterations, space.damping = ITERATIONS, 1.0
        space.collision_bias, space.collision_slop = COLLISION_BIAS, COLLISION_SLOP
        space.gravity = plane.to2d(scene.gravity)
        self.elasticity, self.friction = per_shape_coefficients(scene.contact)
        self.moments = rigid.inertia[:, 1, 1]  # body y = world y (checked by the refusal)
        self.bodies, self.circles = [], []
        for i in range(len(rigid)):  # build time: one pymunk body per scene body
            body = pymunk.Body(float(rigid.mass[i]), float(self.moments[i]))
            body.position, body.velocity = plane.to2d(rigid.position[i]), plane.to2d(
                rigid.velocity[i])
            body.angular_velocity = plane.spin_sign * rigid.angular_velocity[i, 1]
            j = int(np.flatnonzero(shapes.body == i)[0])
            circle = pymunk.Circle(body, float(shapes.radius[j]))
            circle.elasticity, circle.friction = self.elasticity, self.friction
            self.bodies.append(body)
            self.circles.append(circle)
        self.segments = [self._segment(pymunk, p, n)
                         for p, n in zip(walls.point, walls.normal)]
        space.add(*self.bodies, *self.circles, *self.segments)

    def _segment(self, pymunk, point, normal):
        p, n = np.array(self.plane.to2d(point)), np.array(self.plane.to2d(normal))
        t = np.array([-n[1], n[0]]) / np.linalg.norm(n) * WALL_HALF_LENGTH
        seg = pymunk.Segment(self.space.static_body, tuple(p - t), tuple(p + t), 0.0)
        seg.elasticity, seg.friction = self.elasticity, self.friction
        return seg

    def _step_impl(self, n):
        space_step, dt = self.space.step, self.dt
        for _ in range(n):  # pymunk has no multi-step call
            space_step(dt)

    def _observe(self):
        n, plane = len(self.bodies), self.plane
        i, k = plane.axes
        x, v, w = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
        angle = np.zeros(n)
        for row, body in enumerate(self.bodies):  # pymunk has no array access
            x[row, i], x[row, k] = body.position
            v[row, i], v[row, k] = body.velocity
            w[row, 1] = plane.spin_sign * body.angular_velocity
            angle[row] = plane.spin_sign * body.angle
        turn = np.zeros((n, 4))
        turn[:, 0], turn[:, 2] = np.cos(0.5 * angle), np.sin(0.5 * angle)
        q = _quat_product(turn, self.rigid.orientation)
        return {"x": x, "v": v, "q": q, "w": w, "orientation_defect": np.zeros(n)}

    def settings(self):
        return {
            "integrator": {"name": "symplectic_euler_dk", "order": 1,
                           "family": "symplectic Euler", "explicit": True, "symplectic": False,
                           "native": "cpSpaceStep: drift (x += h v, angle += h w), then "
                                     "gravity kick and contact impulses",
                           "note": "drift-kick: s_k = a h^2 k (k - 1) / 2 on a constant a"},
            "dtype": "float64", "threads": 1,
            "plane": "refsim (x, z) -> pymunk (x, y), y-up; observed y = 0",
            "spin_sign": self.plane.spin_sign,
            "contact_model": "impulse", "detection": "discrete",
            "space": {"iterations": self.space.iterations, "damping": self.space.damping,
                      "gravity": list(self.space.gravity),
                      "collision_bias": self.space.collision_bias,
                      "collision_slop": self.space.collision_slop,
                      "collision_persistence": self.space.collision_persistence},
            "bodies": {"mass": [b.mass for b in self.bodies],
                       "moment": [b.moment for b in self.bodies],
                       "moment_meaning": "scene inertia about body y = world y"},
            "shapes": "Circle of the shape's radius per body; static Segment (radius 0, "
                      f"+-{WALL_HALF_LENGTH:g} m) per wall",
            "friction_mapping": f"sqrt(mu) = {self.friction!r} on every circle and segment "
                                "(Chipmunk multiplies the pair's values)",
            "elasticity": f"sqrt(e) = {self.elasticity!r} on every shape",
            "energy": "computed from x, v, w; Body.kinetic_energy (twice KE) is not used",
            "python_per_step": "one Python call to space.step(dt) per step; timings include it",
        }

    def close(self):
        self.space = self.bodies = self.circles = self.segments = None


def _quat_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a (x) b of (n, 4) quaternions (w, x, y, z)."""
    aw, av, bw, bv = a[:, :1], a[:, 1:], b[:, :1], b[:, 1:]
    return np.concatenate([aw * bw - np.sum(av * bv, axis=1, keepdims=True),
                           aw * bv + bw * av + np.cross(av, bv)], axis=1)
