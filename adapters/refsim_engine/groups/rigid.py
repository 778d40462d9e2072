"""The in-house engine's rigid-body group: free rigid bodies (Newton-Euler, world frame) under
gravity, `refsim.models.rigid_body`, in one of four orientation formulations (engine
variants, `refsim.models.rigid_orientation`): quat_exp (default), quat_normalised,
matrix_printed, matrix_polar; stepped by a fixed-step `refsim.integrators` stepper.

Observes x, v, q (matrix formulations: the quaternion of the polar factor, w >= 0), w (world),
`orientation_defect` (n,) (the formulation's defect, see rigid_orientation), and the extras
`energy` () J (sum over bodies of 1/2 m |v|^2 + 1/2 w . L - m g . x), `angular_momentum`
(n, 3) world L = I_w w about each centre of mass, `det_defect` (n,) det R - 1.
Batched stepping: every array carries the body axis (n, ...), so n bodies step in one numpy
call per stage; the system itself also takes leading batch axes ((batch, n, ...) states).
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup
from refsim.integrators import get_integrator
from refsim.models.rigid_body import RigidBodySystem
from refsim.models.rigid_orientation import FORMULATIONS, get_formulation
from refsim.scene import RigidBodies

from ..stepped import SteppedSim

DEFAULT_FORMULATION = "quat_exp"
VARIANTS = (DEFAULT_FORMULATION,) + tuple(f for f in FORMULATIONS if f != DEFAULT_FORMULATION)
INTEGRATORS = ("symplectic_euler", "explicit_euler", "midpoint", "rk4", "implicit_midpoint")


class RigidSim(SteppedSim):
    def __init__(self, scene, dt, stepper, formulation):
        rigid, self.scene = scene.part(RigidBodies), scene
        self.formulation = get_formulation(formulation)
        system = RigidBodySystem(rigid.mass, rigid.inertia, scene.gravity, self.formulation)
        x0 = system.configuration(rigid.position, rigid.orientation)
        super().__init__(dt, stepper, system, x0, system.velocity(rigid.velocity,
                                                                   rigid.angular_velocity))

    def stages(self):
        gravity = ["gravity"] if np.any(self.scene.gravity) else []
        return gravity + ["gyroscopic_explicit", f"orientation:{self.formulation.name}",
                          f"integrate:{self.stepper.name}"]

    def _observe(self):
        x, v = self.coordinates()
        system = self.system
        return {"x": x[:, :3], "v": v[:, :3], "q": system.quaternion(x), "w": v[:, 3:],
                "orientation_defect": system.defect(x),
                "energy": float(np.sum(system.energy(x, v))),
                "angular_momentum": system.angular_momentum(x, v),
                "det_defect": self.formulation.det_defect(x[:, 3:])}

    def settings(self):
        corrected = hasattr(self.system, "dexpinv")
        return {**self.base_settings(), "integrator": self._integrator_entry(),
                "formulation": self.formulation.name,
                "formulation_description": self.formulation.description,
                "formulations": {f.name: f.description for f in FORMULATIONS.values()},
                "gyroscopic_term": "explicit: w x (I_w w) evaluated at the stepper's stages",
                "rk_stage_correction": ("dexpinv of the formulation's map (RKMK)" if corrected
                                        else "none (the map is not on the group)"),
                "angular_damping": 0.0, "linear_damping": 0.0, "velocity_clamp": None}


    def _integrator_entry(self) -> dict:
        """The stepper as tolerances read it, on this system: not symplectic (the gyroscopic
        term is explicit and (q, w) are not canonical: symplectic Euler's energy grows,
        measured), and no higher order than the formulation allows."""
        entry = dict(self.stepper.describe())
        limit = self.formulation.order_limit
        if limit is not None and entry["order"] > limit:
            entry.update(order=limit, nominal_order=self.stepper.order,
                         order_note=f"{self.formulation.name} is first order under any "
                                    "stepper: its update leaves the rotation group")
        if entry.get("symplectic"):
            entry.update(symplectic=False, symplectic_note="not symplectic on a rigid body: "
                         "the gyroscopic term is explicit and (q, w) are not canonical "
                         "coordinates; the energy of a tumbling body grows")
        return entry


def _claims(scene) -> bool:
    """Scenes whose only part is `rigid` (no particles, springs, joints, walls, contact
    model, fluid, networks, meshes, grids or extra parts)."""
    return scene.part(RigidBodies) is not None and scene.part_kinds() == {"rigid"} \
        and scene.contact is None


def _supports(engine, scene, integrator):
    if scene.dim != 3:
        return "refsim rigid bodies are 3D (quaternion or 3x3 orientation)"
    return None


def _formulations(engine, scene):
    return VARIANTS


def _build(engine, scene, dt, integrator, formulation):
    return RigidSim(scene, dt, get_integrator(integrator), formulation or DEFAULT_FORMULATION)


MODEL_GROUP = ModelGroup(name="rigid", build=_build, claims=_claims,
                         parts=frozenset({"rigid"}), features=frozenset({"rigid", "gravity"}),
                         supports=_supports, formulations=_formulations, integrators=INTEGRATORS)
