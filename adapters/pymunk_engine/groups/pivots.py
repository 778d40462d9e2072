"""pymunk's pivoted rigid bodies: planar scenes holding `RigidBodies` and `RigidPivots`.

pymunk is 2D: it takes a pivoted scene only when every motion stays in its plane (a 3D scene's
x-z plane, a 2D scene's x-y plane; adapters/pymunk_engine/plane.py): centres, velocities,
anchors and gravity in the plane, each body's angular velocity along the plane's normal, and
that normal a principal axis of its world inertia (else the spin would need an out-of-plane
torque). Each body is a `pymunk.Body(mass, moment)` with the moment = the world inertia about the
centre of mass across the plane (I_w[n, n], n the normal), and a `PivotJoint` from the static
body at the anchor to the body point (world anchor - centre at angle 0, in the body's frame)
with error_bias = 0 (docs/engine_notes.md#pymunk-joint-bias-loses-energy: pymunk's default bias
loses energy; 0 makes each step's bias velocity carry the whole gap -(gap)/h,
src/cpPivotJoint.c). No shapes (nothing collides).

Step (cpSpaceStep, pymunk's own `symplectic_euler_dk`): positions and angles drift with the old
velocities, then gravity kicks the velocities and the pivot's impulse (one 2x2 solve per joint,
exact in the first of the 10 iterations for one joint on a static body) projects them: maximal
coordinates, first order, the pivot held to O(h^2) per step.
Observables: x, v (the plane's axes, zero along the normal), q = exp(normal angle/2) (x) q0 with
the body's angle (0 at t = 0, sign mapped by Plane.spin_sign), w (world, along the normal),
orientation_defect 0 (an angle has no defect: the rotation is exact by construction), and
pivot_gap (k,) m = |centre + R body_point - anchor| per pivot (pymunk's drift off the pivot).
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup, Sim
from refsim.scene import RigidBodies
from refsim.scene.pivots import RigidPivots, check_on_anchor

from ..plane import Plane
from ..space import ITERATIONS

WHO = "pymunk adapter"
INERTIA_PLANE_TOL = 1e-12  # |I_w[n, other]| <= this * max |I_w|: R from a unit quaternion is
# exact to a few ulps, so a principal axis along the normal leaves ~1e-15 relative; 1e-12 is
# far below any physical tilt of the axes (which would need an out-of-plane torque)
NATIVE_STEP = ("cpSpaceStep: position_func (x += h v, angle += h w), constraint preStep at the "
               "new positions, velocity_func (v += h g), PivotJoint impulse iterations")


def _rotate(quat: np.ndarray, vec: np.ndarray) -> np.ndarray:
    """Rotate each vec (n, 3) by its unit quaternion (n, 4) (w, x, y, z)."""
    w, u = quat[:, :1], quat[:, 1:]
    t = 2.0 * np.cross(u, vec)
    return vec + w * t + np.cross(u, t)


def _world_inertia(rigid) -> np.ndarray:
    """(n, 3, 3) R I0 R^T, columns rotated one by one (vectorised over bodies)."""
    q = rigid.orientation
    cols = [_rotate(q, rigid.inertia[:, :, j]) for j in range(3)]
    half = np.stack(cols, axis=2)  # R I0
    rows = [_rotate(q, half[:, j, :]) for j in range(3)]  # (R (R I0)^T)^T = R I0 R^T
    return np.stack(rows, axis=1)


def claims(scene) -> bool:
    return scene.part(RigidBodies) is not None and scene.part(RigidPivots) is not None


def plane_refusal(scene) -> str | None:
    """None when every pivoted body moves in pymunk's plane, else why not ("pymunk is 2D")."""
    rigid, pivots = scene.part(RigidBodies), scene.part(RigidPivots)
    k = Plane(scene.dim).normal_axis
    others = [a for a in range(3) if a != k]
    inertia_w = _world_inertia(rigid)
    tilt = np.abs(inertia_w[:, k, others]).max(axis=1)
    if (scene.gravity[k] != 0 or np.any(rigid.position[:, k]) or np.any(rigid.velocity[:, k])
            or np.any(rigid.angular_velocity[:, others]) or np.any(pivots.anchor[:, k])):
        axis = "xyz"[k]
        return (f"pymunk is 2D: a pivoted scene must keep centres, velocities, anchors and "
                f"gravity at {axis} = 0 and angular velocities along {axis}")
    if np.any(tilt > INERTIA_PLANE_TOL * np.abs(inertia_w).max(axis=(1, 2))):
        return (f"pymunk is 2D: the plane's normal ({'xyz'[k]}) must be a principal axis of "
                f"every body's inertia (else spinning in the plane needs an out-of-plane "
                f"torque)")
    return None


def supports(engine, scene, integrator):
    pivots, rigid = scene.part(RigidPivots), scene.part(RigidBodies)
    try:
        check_on_anchor(pivots, rigid)
    except ValueError as exc:
        return f"{WHO}: {exc}"
    if len(pivots) != len(rigid):
        return (f"{WHO}: every rigid body of a pivoted scene must have a pivot; free bodies "
                f"beside pivoted ones are not modelled by this group")
    return plane_refusal(scene)


def build(engine, scene, dt, integrator, formulation):
    import pymunk
    return PymunkPivotSim(pymunk, scene, dt)


MODEL_GROUP = ModelGroup(
    name="pivots", build=build, claims=claims, parts=frozenset({"rigid", "rigid_pivots"}),
    features=frozenset({"rigid", "pivots", "gravity"}), supports=supports,
    formulations=lambda engine, scene: ("",), integrators=("symplectic_euler_dk",))


class PymunkPivotSim(Sim):
    """One pymunk Body and PivotJoint per pivot; stepped by space.step(dt)."""

    def __init__(self, pymunk, scene, dt):
        self.scene, self.dt, self.steps = scene, dt, 0
        self.plane = plane = Plane(scene.dim)
        self.pivots, self.rigid = scene.part(RigidPivots), scene.part(RigidBodies)
        rigid = self.rigid
        self.order = self.pivots.body
        self.moments = _world_inertia(rigid)[self.order, plane.normal_axis, plane.normal_axis]
        self.space = space = pymunk.Space(threaded=False)
        space.iterations, space.damping = ITERATIONS, 1.0
        space.gravity = plane.to2d(scene.gravity)
        self.bodies, self.joints = [], []
        for i, b in enumerate(self.order):  # build time: one pymunk body per pivot
            body = pymunk.Body(float(rigid.mass[b]), float(self.moments[i]))
            body.position = plane.to2d(rigid.position[b])
            body.velocity = plane.to2d(rigid.velocity[b])
            body.angular_velocity = plane.spin_sign * rigid.angular_velocity[b, plane.normal_axis]
            local = np.subtract(plane.to2d(self.pivots.anchor[i]), body.position)
            joint = pymunk.PivotJoint(space.static_body, body, plane.to2d(self.pivots.anchor[i]),
                                      tuple(local))
            joint.error_bias = 0.0
            self.bodies.append(body)
            self.joints.append(joint)
        space.add(*self.bodies, *self.joints)

    def _step_impl(self, n):
        space_step, dt = self.space.step, self.dt
        for _ in range(n):  # pymunk has no multi-step call
            space_step(dt)

    def _observe(self):
        n, plane = len(self.rigid), self.plane
        i, k = plane.axes
        normal = plane.normal_axis
        x, v, w = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
        angle = np.zeros(n)
        for row, body in zip(self.order, self.bodies):  # pymunk has no array access
            x[row, i], x[row, k] = body.position
            v[row, i], v[row, k] = body.velocity
            w[row, normal] = plane.spin_sign * body.angular_velocity
            angle[row] = plane.spin_sign * body.angle
        turn = np.zeros((n, 4))
        turn[:, 0], turn[:, 1 + normal] = np.cos(0.5 * angle), np.sin(0.5 * angle)
        q = _quat_product(turn, self.rigid.orientation)
        gap = x[self.order] + _rotate(q[self.order], self.pivots.body_point) - self.pivots.anchor
        return {"x": x, "v": v, "q": q, "w": w, "orientation_defect": np.zeros(n),
                "pivot_gap": np.linalg.norm(gap, axis=1)}

    def settings(self):
        plane = self.plane
        return {
            "integrator": {"name": "symplectic_euler_dk", "order": 1,
                           "family": "symplectic Euler", "explicit": True, "symplectic": False,
                           "native": NATIVE_STEP,
                           "note": "maximal coordinates: drift, gravity kick, then the pivot "
                                   "impulse projects the velocities; the pivot is held to "
                                   "O(h^2) per step by the full bias (error_bias = 0), which "
                                   "is not a symplectic map"},
            "dtype": "float64", "threads": 1,
            "plane": ("refsim (x, z) -> pymunk (x, y), y-up; observed y = 0" if plane.dim == 3
                      else "refsim (x, y) -> pymunk (x, y)"),
            "spin_sign": plane.spin_sign,
            "space": {"iterations": self.space.iterations, "damping": self.space.damping,
                      "gravity": list(self.space.gravity), "threaded": self.space.threaded},
            "bodies": {"mass": [b.mass for b in self.bodies],
                       "moment": [b.moment for b in self.bodies],
                       "moment_meaning": "the world inertia about the centre of mass across "
                                         "the plane, (R I0 R^T)[n, n]",
                       "shapes": "none (nothing collides)"},
            "joints": {"type": "PivotJoint (static body at the anchor, body at the body point)",
                       "error_bias": [j.error_bias for j in self.joints],
                       "fix": "error_bias = 0 "
                              "(docs/engine_notes.md#pymunk-joint-bias-loses-energy: "
                              "pymunk's default bias loses energy); each step's bias "
                              "velocity is -(gap)/h",
                       "max_bias": [str(j.max_bias) for j in self.joints],
                       "max_force": [str(j.max_force) for j in self.joints]},
            "orientation": "the body's angle about the plane's normal: q = exp(angle/2) (x) q0; "
                           "orientation_defect is 0 by construction (an angle has none)",
            "energy": "computed from x, v, w; Body.kinetic_energy (twice KE) is not used",
            "python_per_step": "one Python call to space.step(dt) per step; timings include it",
        }

    def close(self):
        self.space = self.bodies = self.joints = None


def _quat_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a (x) b of (n, 4) quaternions (w, x, y, z)."""
    aw, av, bw, bv = a[:, :1], a[:, 1:], b[:, :1], b[:, 1:]
    return np.concatenate([aw * bw - np.sum(av * bv, axis=1, keepdims=True),
                           aw * bv + bw * av + np.cross(av, bv)], axis=1)
