"""Point masses without contacts, one `BodyPlan` each (group "particles" decides which): a free
particle (3 slides), a mass on a spring to a fixed anchor (1 slide joint with stiffness) and a
mass on a rod (1 hinge through the anchor).

Each builder takes the body record, its spring or rod record and the scene-wide values it needs,
and raises ValueError with the one-sentence reason `supports` reports."""
from __future__ import annotations

import math

import numpy as np

from .body_plan import BodyPlan

# kg m^2: docs/engine_notes.md#mujoco-point-mass-inertia (1e-12 clean, 1e-9 a 1e-8 error
# under RK4)
POINT_INERTIA = 1e-12
_GEOMETRY_RTOL = 1e-9  # a spring body must stay on its anchor line to this (rods: common)
WHO = "mujoco adapter"  # how the reasons name this engine


def particle_plan(i, body, drag) -> BodyPlan:
    """A free point mass: 3 slides, each damped by the linear drag b."""
    return BodyPlan("particle", i, body.mass, body.position, damping=drag,
                    qvel0=body.velocity)


def hinge_plan(i, body, joint, drag) -> BodyPlan:
    """Hinge through the anchor; qpos = 0 is the initial pose, qvel the initial rate (the
    start geometry was checked by rod_start_refusal)."""
    r0 = np.subtract(body.position, joint.anchor)
    axis, length = np.asarray(joint.axis), joint.length
    omega = float(np.cross(r0, body.velocity) @ axis) / length ** 2
    return BodyPlan("hinge", i, body.mass, body.position, axis=tuple(axis),
                    joint_pos=tuple(-r0), damping=drag * length ** 2,
                    qvel0=(omega,))


def spring_plan(i, body, spring, gravity, drag) -> BodyPlan:
    """Slide along u = (x0 - anchor)/d0; spring force -k (q + d0 - L0) = -k (d - L0)."""
    r0 = np.subtract(body.position, spring.anchor)
    d0 = float(np.linalg.norm(r0))
    if d0 == 0:
        raise ValueError("mujoco adapter: a spring body may not start on its anchor")
    u = r0 / d0
    v0, g = np.asarray(body.velocity), np.asarray(gravity)
    if np.linalg.norm(v0 - (v0 @ u) * u) > _GEOMETRY_RTOL * max(np.linalg.norm(v0), 1.0) or \
            np.linalg.norm(g - (g @ u) * u) > _GEOMETRY_RTOL * max(np.linalg.norm(g), 1.0):
        raise ValueError("mujoco adapter: a spring body must move along the anchor-body line "
                         "(velocity and gravity along it); a slide-joint spring is 1D")
    if _closest_approach(body.mass, spring.stiffness, spring.rest_length, g @ u, d0,
                         v0 @ u) <= 0:
        raise ValueError("mujoco adapter: this spring would swing through its anchor, which a "
                         "slide-joint spring does not model")
    return BodyPlan("spring", i, body.mass, body.position, axis=tuple(u),
                    stiffness=spring.stiffness, springref=spring.rest_length - d0,
                    damping=spring.damping + drag, qvel0=(float(v0 @ u),))


def _closest_approach(m, k, rest, g_u, d0, v0):
    """Smallest anchor distance of the undamped 1D motion (damping only lowers the energy)."""
    centre = rest + m * g_u / k
    amplitude = math.sqrt((d0 - centre) ** 2 + m * v0 * v0 / k)
    return centre - amplitude
