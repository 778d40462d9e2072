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

Contacts (feature "contacts", planar scenes only) use the same step (src/cpSpaceStep.c,
src/cpArbiter.c, src/cpCollision.c): after the drift, circles that overlap (distance < r1 + r2,
strictly) get an arbiter with the normal along the centre line at the drifted positions; its
target bounce velocity is e times the normal relative velocity before the kick; each impulse
pass sets the normal relative velocity to -bounce (accumulated normal impulse >= 0) and clamps
the tangential impulse to u times the accumulated normal impulse. That is Newton's restitution
law with Coulomb stick/slide, applied at the step in which the overlap is first seen: there is
no continuous collision detection, so the contact normal is the one of the penetrated pose.
Head-on impacts are exact whatever the step; an oblique impact's normal is rotated by the
overlap (an O(dt) error in the outcome). Walls are static segments.

ENGINE_NOTES.md facts applied (pymunk 7.3.1): no damping (space.damping = 1.0 keeps
1.0^h = all of the velocity), zero gravity unless the scene sets it, 10 iterations, mass and
moment > 0 with moment = inf for a point mass, `Body.kinetic_energy` (m v^2 + I w^2, twice the
kinetic energy) never used, springs as `DampedSpring`, the `PinJoint` bias made explicit,
elasticity and friction multiplied per pair (sqrt of e and mu on every shape).
"""
from __future__ import annotations

import math

import numpy as np

from refsim.engine import Engine, Sim

ITERATIONS = 10  # pymunk's default, kept; one constraint per body is solved in the first pass
# Contact position correction off: collision_bias = 1 makes the bias coefficient 1 - 1^h = 0,
# so positions move only with the velocities (a pure impulse model); slop 0 is then inert.
# pymunk's defaults (kept in PYMUNK_DEFAULTS for the report) are slop 0.1 (a pixel-scale
# length, the spheres' radius here) and bias 0.9^60 = 1.797e-3.
COLLISION_BIAS, COLLISION_SLOP = 1.0, 0.0
PYMUNK_DEFAULTS = {"collision_slop": 0.1, "collision_bias": 0.9 ** 60,
                   "collision_persistence": 3, "iterations": 10}
WALL_HALF_LENGTH = 100.0  # wall segments span +- this many scene sizes around the wall point
JOINT_VARIANTS = ("", "default_bias")
DRAG_VARIANTS = ("", "space_damping")
NATIVE_STEP = ("cpSpaceStep: position_func (x += h v), constraint preStep at the new positions "
               "(spring impulse), velocity_func (v += h (g + f/m)), impulse iterations")


class PymunkEngine(Engine):
    name = "pymunk"
    package = "pymunk"
    capabilities = frozenset({"gravity", "springs", "joints", "drag", "contacts", "walls"})
    dims = (2, 3)
    integrators = ("symplectic_euler_dk",)

    def supports(self, scene, integrator=None):
        reason = super().supports(scene, integrator)
        if reason:
            return reason
        if scene.dim == 3 and not scene.stays_in_xz_plane():
            if scene.contact is not None:
                return ("pymunk is 2D: these spheres move in 3D (positions, velocities or wall "
                        "normals off the x-z plane, e.g. the box), which a 2D engine cannot "
                        "simulate")
            return ("pymunk is 2D: it takes a 3D scene only when all motion stays in the x-z "
                    "plane (y = 0, no y velocity, gravity or anchor offset, hinge axes along y)")
        if scene.dim == 2 and not scene.stays_in_plane(2):
            return ("pymunk is 2D: a 2D scene must have zero z components (positions, "
                    "velocities, gravity, anchors) and hinge axes along z")
        if any(np.delete(b.angular_velocity, _normal_axis(scene)).any() for b in scene.bodies):
            return "pymunk is 2D: bodies may only spin about the axis normal to the plane"
        if scene.walls and scene.contact is None:
            return "pymunk walls need a contact model (scene.contact) to collide with"
        if scene.contact is not None and any(b.radius <= 0 for b in scene.bodies):
            return "pymunk contacts: every body must be a sphere (circle) with radius > 0"
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


class PymunkSim(Sim):
    def __init__(self, pymunk, scene, dt, variant):
        self.scene, self.dt, self.variant, self.steps = scene, dt, variant, 0
        self.axes = (0, 2) if scene.dim == 3 else (0, 1)
        self.space = _make_space(pymunk, scene, variant, self._to2d(scene.gravity))
        self.bodies = [self._make_body(pymunk, b) for b in scene.bodies]
        self.shapes = self._make_shapes(pymunk) if scene.contact is not None else []
        self.walls = [self._make_wall(pymunk, w) for w in scene.walls]
        self.space.add(*self.bodies, *self.shapes, *self.walls)  # one batched add
        self.springs = [self._add_spring(pymunk, s) for s in scene.springs]
        self.joints = [self._add_joint(pymunk, j) for j in scene.joints]
        # drag as the force -b v set before each step (see `step`), unless pymunk's global
        # damping carries it (variant space_damping)
        self.drag = scene.linear_drag if variant != "space_damping" else 0.0

    # -- building -------------------------------------------------------------------------------
    def _to2d(self, vec):
        return (float(vec[self.axes[0]]), float(vec[self.axes[1]]))

    def _spin_sign(self):
        """pymunk's rotation axis is its +z, x_pm cross y_pm; in a 3D scene that is refsim's
        x cross z = -y, so refsim's spin about +y is minus pymunk's angular velocity (a point
        at +x on a body spinning +w about y moves along -z: w y cross x = -w z). 2D: same axis."""
        return -1.0 if self.scene.dim == 3 else 1.0

    def _make_body(self, pymunk, body):
        """ENGINE_NOTES (pymunk 7.3.1): mass and moment must be > 0; moment = inf for a point
        mass (no rotation to integrate). A sphere's moment is the scene's inertia (2/5 m r^2),
        set here and never recomputed: its circle shape carries no mass or density."""
        moment = body.inertia if body.inertia > 0 else math.inf
        pb = pymunk.Body(body.mass, moment)
        pb.position, pb.velocity = self._to2d(body.position), self._to2d(body.velocity)
        pb.angular_velocity = self._spin_sign() * body.angular_velocity[_normal_axis(self.scene)]
        return pb

    def _make_shapes(self, pymunk):
        """One Circle per sphere. Chipmunk multiplies the two shapes' coefficients per contact
        (cpArbiterUpdate: e = a.e * b.e, u = a.u * b.u; measured: 0.5 on each gives e = 0.25),
        so every shape carries sqrt(e) and sqrt(mu): the pair's product is e (mu) to 1 ulp."""
        e, mu = self._shape_coefficients()
        shapes = []
        for pb, body in zip(self.bodies, self.scene.bodies):
            circle = pymunk.Circle(pb, body.radius)
            circle.elasticity, circle.friction = e, mu
            shapes.append(circle)
        return shapes

    def _shape_coefficients(self):
        contact = self.scene.contact
        return math.sqrt(contact.restitution), math.sqrt(contact.friction)

    def _wall_length(self):
        """Half-length of a wall segment: pymunk has no half-plane, so a wall is a static
        segment spanning WALL_HALF_LENGTH scene sizes (bodies' spread about the wall points)."""
        pts = np.array([b.position for b in self.scene.bodies] +
                       [w.point for w in self.scene.walls])
        size = max(1.0, float(np.ptp(pts, axis=0).max()))
        return WALL_HALF_LENGTH * size

    def _make_wall(self, pymunk, wall):
        """A Segment (radius 0) on the static body along the wall line, with the same sqrt(e),
        sqrt(mu) as the circles so a sphere-wall contact gets e and mu. Two-sided: the
        scene's inward normal only says where the spheres are."""
        p, n = np.array(self._to2d(wall.point)), np.array(self._to2d(wall.normal))
        t = np.array([-n[1], n[0]]) / np.linalg.norm(n) * self._wall_length()
        seg = pymunk.Segment(self.space.static_body, tuple(p - t), tuple(p + t), 0.0)
        seg.elasticity, seg.friction = self._shape_coefficients()
        return seg

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
        if self.scene.contact is not None:  # rotation: spheres in contact can spin
            w = np.zeros((nb, 3))
            w[:, _normal_axis(self.scene)] = [self._spin_sign() * b.angular_velocity
                                               for b in self.bodies]
            out["w"] = w
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
                                    "be > 0), else the scene's inertia",
                          "shapes": ("a Circle per sphere" if self.scene.contact is not None
                                     else "none (nothing collides: no collision detection)")},
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
        if self.scene.contact is not None:
            out.update(self._contact_settings())
        return out

    def close(self):
        self.space = self.bodies = self.springs = self.joints = None
        self.shapes = self.walls = None

    # -- settings helpers -----------------------------------------------------------------------
    def _contact_settings(self):
        e, mu = self._shape_coefficients()
        space = self.space
        return {"contact_model": "impulse", "detection": "discrete",
                "contact": _CONTACT_FACTS,
                "restitution": {"e": self.scene.contact.restitution, "shape_elasticity": e,
                                "effective": e * e, "mapping": "sqrt(e) on every shape: "
                                "Chipmunk multiplies the two shapes' elasticities "
                                "(cpArbiterUpdate, measured: 0.5 on each gave e = 0.25)"},
                "friction": {"mu": self.scene.contact.friction, "shape_friction": mu,
                             "effective": mu * mu, "mapping": "sqrt(mu) on every shape "
                             "(the product, as for elasticity)"},
                "moment": {"values": [b.moment if math.isfinite(b.moment) else "inf"
                                      for b in self.bodies],
                           "source": "the scene's inertia (2/5 m r^2 for a solid sphere) set "
                                     "on pymunk.Body; pymunk.moment_for_circle(m, 0, r) would "
                                     "give a disc's 1/2 m r^2, 25 % too large for a sphere; the "
                                     "circles carry no mass/density, so pymunk never "
                                     "recomputes it"},
                "collision_slop": space.collision_slop,
                "collision_bias": space.collision_bias,
                "collision_bias_coef_per_step": 1.0 - space.collision_bias ** self.dt,
                "collision_persistence": space.collision_persistence,
                "position_correction": ("off: collision_bias = 1 gives a bias coefficient "
                                        "1 - 1^dt = 0, so positions move only with the "
                                        "velocities; Chipmunk's correction is a split impulse "
                                        "(v_bias, used in the next drift only) that never "
                                        "enters the velocity, so it cannot add push-out "
                                        "velocity either way"),
                "defaults_changed": {"collision_slop": [PYMUNK_DEFAULTS["collision_slop"],
                                                        space.collision_slop],
                                     "collision_bias": [PYMUNK_DEFAULTS["collision_bias"],
                                                        space.collision_bias]},
                "solver_iterations": space.iterations,
                "solver_iterations_note": "pymunk's default 10 kept: one pass settles an "
                                          "isolated impact (normal, then tangential); "
                                          "simultaneous contacts (the cradle) are Gauss-Seidel "
                                          "and leave ~1e-6 of the energy at 10 passes",
                "ccd": "none (pymunk has no continuous collision detection): overlaps are "
                       "found at the drifted positions once per step; a body moving more "
                       "than about its diameter per step can tunnel",
                "broadphase": "default bounding-box tree (cpBBTree)",
                "sleeping": "off (sleep_time_threshold = inf, pymunk's default)",
                "walls": (f"static Segment (radius 0) per wall, half-length "
                          f"{self._wall_length():g} m about the wall point (pymunk has no "
                          f"half-plane); its closest-point rounding (eps x half-length) tilts "
                          f"the normal by ~eps x half-length / r (measured 2.3e-13 m/s); wall "
                          f"impulses are not reported" if self.walls else "none")}

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
    unless drag is mapped to pymunk's global damping, ENGINE_NOTES' 10 iterations, unthreaded,
    contact position correction off (see COLLISION_BIAS)."""
    space = pymunk.Space(threaded=False)
    space.iterations = ITERATIONS
    space.gravity = gravity
    space.damping = 1.0
    space.collision_bias, space.collision_slop = COLLISION_BIAS, COLLISION_SLOP
    if variant == "space_damping":
        space.damping = math.exp(-scene.linear_drag / scene.bodies[0].mass)
    return space


_CONTACT_FACTS = (
    "Munk2D 2.0.1 (src/cpSpaceStep.c, src/cpArbiter.c, src/cpCollision.c): drift, then circles "
    "overlapping at the drifted positions (distance < r1 + r2) get one contact with normal "
    "along the centre line and points on each surface (lever arm r); bounce = e (normal "
    "relative velocity before the kick); each of `iterations` sequential-impulse passes sets "
    "the normal relative velocity to -bounce (accumulated impulse >= 0) and clamps the "
    "tangential impulse to mu x the accumulated normal impulse (Coulomb stick/slide). A "
    "contact persisting into the next step re-applies its cached impulse (warm start), which "
    "the clamp then removes. Exact for head-on impacts; for an oblique impact the normal is "
    "that of the penetrated pose, an O(dt) error")


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
