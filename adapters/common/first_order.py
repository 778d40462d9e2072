"""What the engines' first-order particle groups share (refsim and taichi run the same models,
refsim/models/advection.py and surface_sampling.py): the steppers offered per field, the
reasons a stepper or a scene is refused, the scene's system and its description."""
from __future__ import annotations

from refsim.integrators import INTEGRATORS
from refsim.integrators.spec import spec_name
from refsim.models.advection import AffineField
from refsim.models.surface_sampling import SphereSampling
from refsim.scene import Particles
from refsim.scene.surface_sampling import SurfaceSampling
from refsim.scene.velocity_field import VelocityField

# offered on affine fields; "rk2" (Ralston) is left out of the matrix: on a linear field
# every two-stage second-order tableau has the same R(z) = 1 + z + z^2/2 as midpoint and Heun
FIELD_INTEGRATORS = ("explicit_euler", "midpoint", "heun", "rk4", "implicit_euler")
SAMPLING_INTEGRATORS = ("explicit_euler", "midpoint", "heun", "rk4")
SECOND_ORDER_ONLY = tuple(n for n in INTEGRATORS if n not in FIELD_INTEGRATORS)
OFFERED = FIELD_INTEGRATORS + SECOND_ORDER_ONLY  # the second-order ones answer `supports`


def first_order_reason(integrator: str, offered) -> str | None:
    """Why `integrator` does not run a first-order scene (None when it does)."""
    name = spec_name(integrator)
    if integrator is None or integrator in offered:
        return None
    if name in FIELD_INTEGRATORS:  # a first-order stepper not offered for this field
        return (f"{integrator!r} solves affine fields only (one linear solve a step): this "
                f"field is not affine in p; offered here: {list(offered)}")
    if name in SECOND_ORDER_ONLY or name in INTEGRATORS:
        return (f"first-order system p' = u(p): {integrator!r} steps second-order systems "
                f"and needs x'' = a; offered here: {list(offered)}")
    return f"first-order scenes: integrator must be one of {list(offered)}, got {integrator!r}"


def claims(scene) -> bool:
    """Particles moved by a VelocityField or sampling a SurfaceSampling surface."""
    return scene.part(VelocityField) is not None or scene.part(SurfaceSampling) is not None


def offered_for(scene) -> tuple:
    return SAMPLING_INTEGRATORS if scene.part(SurfaceSampling) is not None \
        else FIELD_INTEGRATORS


def scene_reason(scene, who: str) -> str | None:
    """Reasons a first-order scene is refused whatever the stepper (shared with taichi)."""
    if scene.part(Particles) is None:
        return f"{who} first-order group: the scene needs particles to move"
    if scene.part(VelocityField) is not None and scene.part(SurfaceSampling) is not None:
        return f"{who} first-order group: one of VelocityField and SurfaceSampling, not both"
    if any(scene.gravity) or scene.linear_drag > 0:
        return (f"{who} first-order group: massless particles moved by their field only "
                "(no gravity, no drag)")
    return None


def make_system(scene):
    """The first-order system of the scene (AffineField or SphereSampling)."""
    field = scene.part(VelocityField)
    if field is not None:
        return AffineField(field.matrix(), field.centre)
    part = scene.part(SurfaceSampling)
    return SphereSampling(part.radius, part.centre, part.sigma, part.alpha)


def model_text(scene) -> str:
    field = scene.part(VelocityField)
    if field is None:
        return ("Witkin-Heckbert: u_i = -P_i grad_{p_i} E_i, E_ij = alpha exp(-|p_i - p_j|^2 / "
                "(2 sigma^2)), sigma fixed; projected onto the sphere after every step")
    return {"rigid_vortex": "u = Omega x (p - c), as u = M (p - c), M = [Omega]_x",
            "quadratic_descent": "u = -grad E = -diag(lambda) (p - c)"}[field.field]
