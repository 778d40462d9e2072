"""MuJoCo's rigid-body group: scenes holding `RigidBodies` (gravity allowed, nothing else).

Each scene body is one MuJoCo body with a `<freejoint/>` (qpos = centre of mass, unit quaternion
(w, x, y, z) body to world; qvel = world-frame linear velocity, BODY-frame angular velocity) and
an explicit `<inertial>`: the scene's mass and the scene's body-frame inertia tensor given as its
principal moments (`diaginertia`) and principal axes (the inertial frame's `quat`), both from
numpy's eigh; a diagonal tensor is given as it is (no rotation). No geoms, contacts off.

Facts (mujoco 4.0.0, measured; reported in `Sim.settings()`):
- MuJoCo's free joint integrates the orientation by the exponential map of the body-frame
  angular velocity and normalises the stored quaternion after every position update (unless
  ||q| - 1| <= mjMINVAL = 1e-15), so `orientation_defect` = |q|^2 - 1 of qpos stays within
  2e-15 + round-off: the renormalisation hides any drift (docs/models.md#rigid-mujoco-free-joint);
  observed to show it;
- it refuses an inertia whose principal moments violate A + B >= C ("use balanceinertia"):
  refused here with the reason rather than balanced (balancing changes the body);
- the free joint's qvel angular part is in the body frame: the scene's world-frame w is rotated
  into it at build time and back when observed.
Integrators (`rigid_methods`), measured on the torque-free asymmetric top (tests):
- Euler: kick then exponential-map drift with the gyroscopic term explicit, i.e. refsim's
  symplectic_euler with quat_exp to round-off; |L| and E GROW at first order in h;
- RK4: order 4 on body w, q and world w; conserves |L| and E to its truncation error;
- implicit and implicitfast: the same step on free bodies (mujoco >= 3.11 applies the
  gyroscopic derivative of a standalone free body in implicitfast too, changelog 3.11.0;
  the description of implicitfast as dropping the gyroscopic terms
  (docs/models.md#rigid-mujoco-free-joint) predates it): linearised backward Euler on the
  gyroscopic term, so |L| and E DECAY at the rate Euler gains them (the tumbling is damped, not
  the spin about a principal axis).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from refsim.engine import ModelGroup
from refsim.scene import RigidBodies

from .rigid_sim import MujocoRigidSim, principal_frame

WHO = "mujoco adapter"
RIGID_INTEGRATORS = ("symplectic_euler", "rk4", "implicit", "implicitfast")
_NOTES = {
    "symplectic_euler": (
        "semi-implicit Euler: v, w_body += h M^-1 (f - c(q_k, v_k)) with the gyroscopic term "
        "w x I w explicit, then x += h v, q <- q exp(h w_body / 2) (exponential map, then "
        "normalised): refsim's symplectic_euler with quat_exp to round-off. Symplectic in "
        "translation only: the explicit gyroscopic kick adds h^2 |L x w|^2 to |L|^2 every "
        "step, so a tumbling body gains |L| and E at first order in h"),
    "rk4": (
        "classical 4-stage Runge-Kutta on (qpos, qvel), stage orientations moved by the "
        "exponential map; measured order 4 on body w, q and world w (torque-free top); "
        "|L| and E drift only by its truncation error"),
    "implicit": (
        "implicit-in-velocity Euler: (M - h dc/dv) dv = h (f - c), the derivative of the "
        "Coriolis/gyroscopic force implicit (linearised backward Euler on w), positions "
        "explicit: a tumbling body loses |L| and E at the rate Euler gains them"),
    "implicitfast": (
        "implicit-in-velocity Euler without the RNE derivatives in general, but (mujoco >= "
        "3.11) with the gyroscopic derivative of each standalone free body solved on its own "
        "6x6 block: on free bodies the same step as implicit to round-off, so it damps the "
        "tumbling (|L| and E lost at first order in h) instead of gaining it"),
}


def rigid_methods() -> dict:
    """The engine's Method records with rigid-body notes (order, what is implicit)."""
    from ..methods import METHODS
    return {name: replace(METHODS[name], symplectic=False, note=_NOTES[name])
            for name in RIGID_INTEGRATORS}


def inertia_refusal(scene) -> str | None:
    """Why MuJoCo would refuse a body's inertia (principal moments A + B < C), or None."""
    for i, tensor in enumerate(scene.part(RigidBodies).inertia):
        a, b, c = np.sort(principal_frame(tensor)[0])
        if a + b < c:
            return (f"{WHO}: rigid body {i} has principal moments {a!r}, {b!r}, {c!r} with "
                    f"A + B < C, which MuJoCo refuses as non-physical (balancing it would "
                    f"change the body)")
    return None


def _claims(scene) -> bool:
    return scene.part(RigidBodies) is not None


def _supports(engine, scene, integrator):
    return inertia_refusal(scene)


def _build(engine, scene, dt, integrator, formulation):
    if integrator not in RIGID_INTEGRATORS:
        raise ValueError(f"mujoco rigid integrator must be one of {list(RIGID_INTEGRATORS)}, "
                         f"got {integrator!r}")
    return MujocoRigidSim(scene, dt, integrator, rigid_methods()[integrator])


MODEL_GROUP = ModelGroup(
    name="rigid", build=_build, claims=_claims, parts=frozenset({"rigid"}),
    features=frozenset({"rigid", "gravity"}), supports=_supports,
    formulations=lambda engine, scene: ("",), integrators=RIGID_INTEGRATORS)
