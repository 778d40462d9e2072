"""pymunk (Chipmunk2D / Munk2D) behind the refsim engine contract.

pymunk is 2D. A 3D scene is accepted only when `scene.stays_in_xz_plane()`: refsim's (x, z)
become pymunk's (x, y), y-up, and observations come back with y = 0. A 2D scene (y-up) maps
(x, y) to (x, y) directly and comes back with z = 0.

The step is Chipmunk's `cpSpaceStep` (pymunk 7.3.1, Munk2D 2.0.1, src/cpSpaceStep.c):
1. `position_func` for every body: x += h v (the step-start velocity);
2. constraint `preStep` at the new positions: a `DampedSpring` applies its spring impulse
   k (L0 - d) h here, a `PinJoint` computes its normal and bias velocity here;
3. `velocity_func` for every body: v = v damping^h + h (g + f / m), then forces are cleared;
4. cached (warm-start) impulses, then `space.iterations` impulse passes over the constraints.
For free bodies and springs that is refsim's drift-kick `symplectic_euler_dk` exactly
(x1 = x + h v; v1 = v + h a(x1)); ENGINE_NOTES.md: free-fall error +g t dt / 2, the opposite
sign of pybullet's kick-drift.

ENGINE_NOTES.md facts applied (pymunk 7.3.1): no damping (space.damping = 1.0 keeps
1.0^h = all of the velocity), zero gravity unless the scene sets it, 10 iterations, mass and
moment > 0 with moment = inf for a point mass, `Body.kinetic_energy` (m v^2 + I w^2, twice the
kinetic energy) never used, springs as `DampedSpring`, the `PinJoint` bias made explicit.
"""
from __future__ import annotations

import math

import numpy as np

from refsim.engine import Engine, Sim

ITERATIONS = 10  # pymunk's default, kept; one constraint per body is solved in the first pass
JOINT_VARIANTS = ("", "default_bias")
DRAG_VARIANTS = ("", "space_damping")
NATIVE_STEP = ("cpSpaceStep: position_func (x += h v), constraint preStep at the new positions "
               "(spring impulse), velocity_func (v += h (g + f/m)), impulse iterations")


class PymunkEngine(Engine):
    name = "pymunk"
    package = "pymunk"
    capabilities = frozenset({"gravity", "springs", "joints", "drag"})
    dims = (2, 3)
    integrators = ("symplectic_euler_dk",)

    def supports(self, scene, integrator=None):
        reason = super().supports(scene, integrator)
        if reason:
            return reason
        if scene.dim == 3 and not scene.stays_in_xz_plane():
            return ("pymunk is 2D: it takes a 3D scene only when all motion stays in the x-z "
                    "plane (y = 0, no y velocity, gravity or anchor offset, hinge axes along y)")
        if scene.dim == 2 and not _stays_in_xy_plane(scene):
            return ("pymunk is 2D: a 2D scene must have zero z components (positions, "
                    "velocities, gravity, anchors) and hinge axes along z")
        if any(np.delete(b.angular_velocity, _normal_axis(scene)).any() for b in scene.bodies):
            return "pymunk is 2D: bodies may only spin about the axis normal to the plane"
        return None

    def variants(self, scene):
        """`default_bias` keeps pymunk's own PinJoint error_bias (ENGINE_NOTES: it loses
        energy); `space_damping` uses pymunk's multiplicative global damping for drag."""
        if scene.joints:
            return JOINT_VARIANTS
        if scene.linear_drag > 0 and len(set(scene.masses)) == 1:
            return DRAG_VARIANTS
        return ("",)

    def build(self, scene, dt, integrator, variant=""):
        reason = self.supports(scene, integrator)
        if reason:
            raise ValueError(reason)
        if not math.isfinite(dt) or dt <= 0:
            raise ValueError(f"dt must be a finite number > 0, got {dt}")
        if variant not in self.variants(scene):
            raise ValueError(f"pymunk variant must be one of {list(self.variants(scene))} for "
                             f"this scene, got {variant!r}")
        import pymunk  # lazily: refsim works without pymunk installed
        return PymunkSim(pymunk, scene, float(dt), variant)


def _normal_axis(scene) -> int:
    """The refsim axis normal to pymunk's plane: y for 3D (x-z plane), z for 2D (x-y)."""
    return 1 if scene.dim == 3 else 2


def _stays_in_xy_plane(scene) -> bool:
    """2D scene check, the counterpart of `Scene.stays_in_xz_plane` with z the normal."""
    if scene.gravity[2] != 0:
        return False
    if any(b.position[2] != 0 or b.velocity[2] != 0 for b in scene.bodies):
        return False
    if any(s.anchor[2] != 0 for s in scene.springs):
        return False
    return all(j.anchor[2] == 0 and abs(j.axis[2]) == 1.0 for j in scene.joints)


class PymunkSim(Sim):
    def __init__(self, pymunk, scene, dt, variant):
        self.scene, self.dt, self.variant, self.steps = scene, dt, variant, 0
        self.axes = (0, 2) if scene.dim == 3 else (0, 1)
        self.space = _make_space(pymunk, scene, variant, self._to2d(scene.gravity))
        self.bodies = [self._add_body(pymunk, b) for b in scene.bodies]
        self.springs = [self._add_spring(pymunk, s) for s in scene.springs]
        self.joints = [self._add_joint(pymunk, j) for j in scene.joints]
        # drag as the force -b v set before each step (see `step`), unless pymunk's global
        # damping carries it (variant space_damping)
        self.drag = scene.linear_drag if variant != "space_damping" else 0.0

    # -- building -------------------------------------------------------------------------------
    def _to2d(self, vec):
        return (float(vec[self.axes[0]]), float(vec[self.axes[1]]))

    def _add_body(self, pymunk, body):
        """ENGINE_NOTES (pymunk 7.3.1): mass and moment must be > 0; moment = inf for a point
        mass (no rotation to integrate)."""
        moment = body.inertia if body.inertia > 0 else math.inf
        pb = pymunk.Body(body.mass, moment)
        pb.position, pb.velocity = self._to2d(body.position), self._to2d(body.velocity)
        spin = body.angular_velocity[_normal_axis(self.scene)]
        # pymunk's +z normal is x cross z = -y for the x-z plane of a 3D scene
        pb.angular_velocity = -spin if self.scene.dim == 3 else spin
        self.space.add(pb)
        return pb

    def _end(self, index, anchor):
        """(pymunk body, local anchor) of a spring end: a body's centre, or a world point on
        the static body (at the origin, unrotated, so local = world)."""
        if index is None:
            return self.space.static_body, self._to2d(anchor)
        return self.bodies[index], (0.0, 0.0)

    def _add_spring(self, pymunk, spring):
        """DampedSpring: force k (L0 - d) along the axis; damping c on the relative velocity
        along the axis (Munk2D src/cpDampedSpring.c)."""
        a, anchor_a = self._end(spring.other, spring.anchor)
        b = self.bodies[spring.body]
        ps = pymunk.DampedSpring(a, b, anchor_a, (0.0, 0.0), spring.rest_length,
                                 spring.stiffness, spring.damping)
        self.space.add(ps)
        return ps

    def _add_joint(self, pymunk, joint):
        """PinJoint from the static body at the anchor to the bob, distance = rod length.
        error_bias = 0 (default variant) makes the bias coefficient 1 - 0^h = 1: each step's
        velocity carries the full rod-length correction -(d - L)/h (src/cpPinJoint.c)."""
        pj = pymunk.PinJoint(self.space.static_body, self.bodies[joint.body],
                             self._to2d(joint.anchor), (0.0, 0.0))
        pj.distance = joint.length
        if self.variant != "default_bias":
            pj.error_bias = 0.0
        self.space.add(pj)
        return pj

    # -- contract -------------------------------------------------------------------------------
    def step(self, n):
        """space.step(dt) n times: pymunk has no multi-step call, so each step is one Python
        call. Drag is the force -b v from the step-start velocity, set before the step (it is
        cleared by the velocity update), which is refsim's drift-kick a(x1, v0) exactly."""
        space_step, dt = self.space.step, self.dt
        if self.drag > 0:
            b, bodies = self.drag, self.bodies
            for _ in range(int(n)):
                for body in bodies:
                    vx, vy = body.velocity
                    body.force = (-b * vx, -b * vy)
                space_step(dt)
        else:
            for _ in range(int(n)):
                space_step(dt)
        self.steps += int(n)

    def observe(self):
        nb = len(self.bodies)
        x, v = np.zeros((nb, 3)), np.zeros((nb, 3))
        i, k = self.axes
        for row, body in enumerate(self.bodies):
            x[row, i], x[row, k] = body.position
            v[row, i], v[row, k] = body.velocity
        out = {"t": self.steps * self.dt, "x": x, "v": v}
        if self.scene.joints:
            out["constraint"] = np.array([np.linalg.norm(x[j.body] - np.asarray(j.anchor))
                                          - j.length for j in self.scene.joints])
        return out

    def settings(self):
        out = {"integrator": self._integrator(), "dtype": "float64", "threads": 1,
               "plane": ("refsim (x, z) -> pymunk (x, y), y-up; observed y = 0"
                         if self.scene.dim == 3 else "refsim (x, y) -> pymunk (x, y)"),
               "space": {"iterations": self.space.iterations, "damping": self.space.damping,
                         "damping_meaning": "velocity kept per second: v *= damping^dt each "
                                            "step; 1.0 = no damping",
                         "gravity": list(self.space.gravity), "threaded": self.space.threaded},
               "bodies": {"moment": "inf for point masses (ENGINE_NOTES: mass and moment must "
                                    "be > 0), else the scene's inertia", "shapes": "none (no "
                                    "collisions in these scenes, so no collision detection)"},
               "energy": "computed by the case from x and v; Body.kinetic_energy (m v^2 + "
                         "I w^2, twice KE) is not used",
               "python_per_step": "one Python call to space.step(dt) per step (pymunk's API has "
                                  "no multi-step call); timings include it"}
        if self.scene.springs:
            out["springs"] = _spring_settings(self.springs)
        if self.scene.joints:
            out["joints"] = _joint_settings(self.joints, self.variant, self.dt)
        if self.scene.linear_drag > 0:
            out["drag"] = self._drag_settings()
        return out

    def close(self):
        self.space = self.bodies = self.springs = self.joints = None

    # -- settings helpers -----------------------------------------------------------------------
    def _integrator(self):
        # the default PinJoint bias dissipates energy of a conservative system (measured:
        # steady loss over 200 s); damping and drag are physics, not the method's doing
        symplectic = self.variant != "default_bias"
        out = {"name": "symplectic_euler_dk", "order": 1, "family": "symplectic Euler",
               "explicit": True, "symplectic": symplectic, "native": NATIVE_STEP}
        if self.scene.joints:
            out["note"] = ("maximal coordinates: drift, then gravity kick and the PinJoint "
                           "impulse; with error_bias = 0 it agrees with generalized-coordinate "
                           "drift-kick to O(dt^2) in angle (not to round-off), with a bounded "
                           "energy error; the default bias dissipates energy (not symplectic)")
        return out

    def _drag_settings(self):
        b = self.scene.linear_drag
        if self.variant == "space_damping":
            return {"method": "space.damping = exp(-b/m): v *= exp(-b dt/m) before the gravity "
                              "kick (exponential, exact for drag alone; differs from the "
                              "explicit -b v at O(dt^2) per step)",
                    "b": b, "space_damping": self.space.damping}
        return {"method": "force -b v from the step-start velocity, set on body.force before "
                          "each space.step (one Python assignment per body per step); equals "
                          "refsim's drift-kick a(x1, v0)", "b": b}


def _make_space(pymunk, scene, variant, gravity):
    """A fresh space: gravity from the scene (pymunk's default is zero), damping 1.0 (none)
    unless drag is mapped to pymunk's global damping, ENGINE_NOTES' 10 iterations, unthreaded."""
    space = pymunk.Space(threaded=False)
    space.iterations = ITERATIONS
    space.gravity = gravity
    space.damping = 1.0
    if variant == "space_damping":
        space.damping = math.exp(-scene.linear_drag / scene.bodies[0].mass)
    return space


def _spring_settings(springs):
    return {"type": "DampedSpring", "stiffness": [s.stiffness for s in springs],
            "rest_length": [s.rest_length for s in springs],
            "damping": [s.damping for s in springs],
            "max_force": [str(s.max_force) for s in springs],
            "force": "impulse k (L0 - d) dt at the drifted position (exact drift-kick)",
            "damping_method": "relative velocity along the axis multiplied by exp(-c dt / "
                              "m_eff) after the kick (exponential; differs from refsim's explicit "
                              "-c (v.u) u by O(dt^2) per step, O(dt) over a run)"}


def _joint_settings(joints, variant, dt):
    bias = [j.error_bias for j in joints]
    return {"type": "PinJoint", "formulation": "maximal coordinates, sequential impulses",
            "error_bias": bias, "bias_coef_per_step": [1.0 - b ** dt for b in bias],
            "bias_meaning": "fraction of the rod-length error left after 1 s; each step's bias "
                            "velocity is -(1 - error_bias^dt) (d - L) / dt",
            "max_bias": [str(j.max_bias) for j in joints],
            "max_bias_meaning": "cap on the bias velocity; inf (pymunk's default, kept) applies "
                                "the whole correction",
            "max_force": [str(j.max_force) for j in joints],
            "fix": ("error_bias = 0 (ENGINE_NOTES: pymunk's default bias loses energy, 0.118 rad "
                    "off at a 2.5 rad start)") if variant != "default_bias" else
                   ("pymunk's default error_bias kept (0.9^60 in single precision = 1.797e-3: "
                    "0.18 % of the error left after one second), shown for comparison")}
