"""The effective pymunk parameters of a PymunkSim, reported with every row (`Sim.settings`):
what the sim was built with (its springs, rods, contact model and walls), never the scene's
kinds."""
from __future__ import annotations

import math

from ..common.contacts import per_shape_coefficients
from .space import PYMUNK_DEFAULTS

NATIVE_STEP = ("cpSpaceStep: position_func (x += h v), constraint preStep at the new positions "
               "(spring impulse), velocity_func (v += h (g + f/m)), impulse iterations")


def sim_settings(sim):
    scene, space = sim.scene, sim.space
    out = {"integrator": integrator_settings(sim.formulation, bool(sim.joints)),
           "dtype": "float64", "threads": 1,
           "plane": ("refsim (x, z) -> pymunk (x, y), y-up; observed y = 0"
                     if scene.dim == 3 else "refsim (x, y) -> pymunk (x, y)"),
           "space": {"iterations": space.iterations, "damping": space.damping,
                     "damping_meaning": "velocity kept per second: v *= damping^dt each "
                                        "step; 1.0 = no damping",
                     "gravity": list(space.gravity), "threaded": space.threaded},
           "bodies": {"moment": "inf for point masses "
                                "(docs/engine_notes.md#pymunk-mass-and-moment: mass and "
                                "moment must be > 0), else the scene's inertia",
                      "shapes": ("a Circle per sphere" if sim.contact is not None
                                 else "none (nothing collides: no collision detection)")},
           "energy": "computed by the case from x and v; Body.kinetic_energy (m v^2 + "
                     "I w^2, twice KE) is not used",
           "python_per_step": "one Python call to space.step(dt) per step (pymunk's API has "
                              "no multi-step call); timings include it"}
    if sim.springs:
        out["springs"] = spring_settings(sim.springs)
    if sim.joints:
        out["joints"] = joint_settings(sim.joints, sim.formulation, sim.dt)
    if scene.linear_drag > 0:
        out["drag"] = drag_settings(scene.linear_drag, sim.formulation, space)
    if sim.contact is not None:
        out.update(contact_settings(sim))
    return out


def integrator_settings(formulation, has_joints):
    # the default PinJoint bias dissipates energy of a conservative system (measured:
    # steady loss over 200 s); damping and drag are physics, not the method's doing
    symplectic = formulation != "default_bias"
    out = {"name": "symplectic_euler_dk", "order": 1, "family": "symplectic Euler",
           "explicit": True, "symplectic": symplectic, "native": NATIVE_STEP}
    if has_joints:
        out["note"] = ("maximal coordinates: drift, then gravity kick and the PinJoint "
                       "impulse; with error_bias = 0 it agrees with generalized-coordinate "
                       "drift-kick to O(dt^2) in angle (not to round-off), with a bounded "
                       "energy error; the default bias dissipates energy (not symplectic)")
    return out


def drag_settings(b, formulation, space):
    if formulation == "space_damping":
        return {"method": "space.damping = exp(-b/m): v *= exp(-b dt/m) before the gravity "
                          "kick (exponential, exact for drag alone; differs from the "
                          "explicit -b v at O(dt^2) per step)",
                "b": b, "space_damping": space.damping}
    return {"method": "force -b v from the step-start velocity, set on body.force before "
                      "each space.step (one Python assignment per body per step); equals "
                      "refsim's drift-kick a(x1, v0)", "b": b}


def spring_settings(springs):
    return {"type": "DampedSpring", "stiffness": [s.stiffness for s in springs],
            "rest_length": [s.rest_length for s in springs],
            "damping": [s.damping for s in springs],
            "max_force": [str(s.max_force) for s in springs],
            "force": "impulse k (L0 - d) dt at the drifted position (exact drift-kick)",
            "damping_method": "relative velocity along the axis multiplied by exp(-c dt / "
                              "m_eff) after the kick (exponential; differs from refsim's explicit "
                              "-c (v.u) u by O(dt^2) per step, O(dt) over a run)"}


def joint_settings(joints, formulation, dt):
    bias = [j.error_bias for j in joints]
    return {"type": "PinJoint", "formulation": "maximal coordinates, sequential impulses",
            "error_bias": bias, "bias_coef_per_step": [1.0 - b ** dt for b in bias],
            "bias_meaning": "fraction of the rod-length error left after 1 s; each step's bias "
                            "velocity is -(1 - error_bias^dt) (d - L) / dt",
            "max_bias": [str(j.max_bias) for j in joints],
            "max_bias_meaning": "cap on the bias velocity; inf (pymunk's default, kept) applies "
                                "the whole correction",
            "max_force": [str(j.max_force) for j in joints],
            "fix": ("error_bias = 0 (docs/engine_notes.md#pymunk-joint-bias-loses-energy: "
                    "pymunk's default bias loses energy, 0.118 rad off at a 2.5 rad start)")
                   if formulation != "default_bias" else
                   ("pymunk's default error_bias kept (0.9^60 in single precision = 1.797e-3: "
                    "0.18 % of the error left after one second), shown for comparison")}


CONTACT_FACTS = (
    "Munk2D 2.0.1 (src/cpSpaceStep.c, src/cpArbiter.c, src/cpCollision.c): drift, then circles "
    "overlapping at the drifted positions (distance < r1 + r2) get one contact with normal "
    "along the centre line and points on each surface (lever arm r); bounce = e (normal "
    "relative velocity before the kick); each of `iterations` sequential-impulse passes sets "
    "the normal relative velocity to -bounce (accumulated impulse >= 0) and clamps the "
    "tangential impulse to mu x the accumulated normal impulse (Coulomb stick/slide). A "
    "contact persisting into the next step re-applies its cached impulse (warm start), which "
    "the clamp then removes. Exact for head-on impacts; for an oblique impact the normal is "
    "that of the penetrated pose, an O(dt) error")


def contact_settings(sim):
    return {"contact_model": "impulse", "detection": "discrete", "contact": CONTACT_FACTS,
            **_coefficient_settings(sim.contact), **_moment_settings(sim.bodies),
            **_correction_settings(sim.space, sim.dt), **_solver_settings(sim)}


def _coefficient_settings(contact):
    e, mu = per_shape_coefficients(contact)
    return {"restitution": {"e": contact.restitution, "shape_elasticity": e,
                            "effective": e * e, "mapping": "sqrt(e) on every shape: "
                            "Chipmunk multiplies the two shapes' elasticities "
                            "(cpArbiterUpdate, measured: 0.5 on each gave e = 0.25)"},
            "friction": {"mu": contact.friction, "shape_friction": mu,
                         "effective": mu * mu, "mapping": "sqrt(mu) on every shape "
                         "(the product, as for elasticity)"}}


def _moment_settings(bodies):
    return {"moment": {"values": [b.moment if math.isfinite(b.moment) else "inf"
                                  for b in bodies],
                       "source": "the scene's inertia (2/5 m r^2 for a solid sphere) set "
                                 "on pymunk.Body; pymunk.moment_for_circle(m, 0, r) would "
                                 "give a disc's 1/2 m r^2, 25 % too large for a sphere; the "
                                 "circles carry no mass/density, so pymunk never "
                                 "recomputes it"}}


def _correction_settings(space, dt):
    return {"collision_slop": space.collision_slop,
            "collision_bias": space.collision_bias,
            "collision_bias_coef_per_step": 1.0 - space.collision_bias ** dt,
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
                                                    space.collision_bias]}}


def _solver_settings(sim):
    walls = ("none" if not sim.walls else
             f"static Segment (radius 0) per wall, half-length "
             f"{sim.wall_half_length:g} m about the wall point (pymunk has no "
             f"half-plane); its closest-point rounding (eps x half-length) tilts "
             f"the normal by ~eps x half-length / r (measured 2.3e-13 m/s); wall "
             f"impulses are not reported")
    return {"solver_iterations": sim.space.iterations,
            "solver_iterations_note": "pymunk's default 10 kept: one pass settles an "
                                      "isolated impact (normal, then tangential); "
                                      "simultaneous contacts (the cradle) are Gauss-Seidel "
                                      "and leave ~1e-6 of the energy at 10 passes",
            "ccd": "none (pymunk has no continuous collision detection): overlaps are "
                   "found at the drifted positions once per step; a body moving more "
                   "than about its diameter per step can tunnel",
            "broadphase": "default bounding-box tree (cpBBTree)",
            "sleeping": "off (sleep_time_threshold = inf, pymunk's default)",
            "walls": walls}
