"""The forces point masses share in the particles and spheres groups: the `particles_t` argpack
(1/m, gravity, linear drag, springs to fixed anchors) and the force stages settings name. Each
takes the arrays and settings its group passes: nothing here reads a scene."""
from __future__ import annotations

import numpy as np

from .kernel_store import to_taichi


def particle_pack(masses, springs, gravity, drag):
    """The `particles_t` argpack: 1/m of `masses` (n,), `gravity` (3,), linear `drag` and the
    springs to anchors of `springs` (a refsim.scene.Springs part, or None: a dummy spring on
    body -1)."""
    from .kernel_types import vec3
    from .particle_kernels import particles_t
    if springs is None:
        rows = {"spring_body": np.array([-1], np.int32), "spring_anchor": np.zeros((1, 3)),
                "spring_k": np.zeros(1), "spring_rest": np.zeros(1), "spring_c": np.zeros(1)}
    else:
        rows = {"spring_body": np.asarray(springs.body, np.int32),
                "spring_anchor": np.array(springs.anchor, float),
                "spring_k": np.array(springs.stiffness, float),
                "spring_rest": np.array(springs.rest_length, float),
                "spring_c": np.array(springs.damping, float)}
    arrays = {"inv_m": 1.0 / np.asarray(masses, float), **rows}
    damped = springs is not None and bool(np.any(springs.damping > 0))
    velocity_dependent = int(drag > 0 or damped)
    return particles_t(gravity=vec3(*gravity), drag=drag,
                       velocity_dependent=velocity_dependent,
                       **{key: to_taichi(arr) for key, arr in arrays.items()})


def force_stages(gravity, drag, springs: bool) -> list:
    """The force terms switched on (non-zero `gravity`, `drag` > 0, `springs` present), in
    settings' order."""
    return [name for name, on in (("gravity", any(gravity)), ("drag", drag > 0),
                                  ("springs", springs)) if on]
