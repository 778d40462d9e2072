"""The in-house engine's pivoted rigid bodies: every rigid body of the scene turns about a
fixed point (`RigidPivots`, a ball joint to the world), `refsim.models.rigid_pivot`, in one of
the rigid group's four orientation formulations (quat_exp default, quat_normalised,
matrix_printed, matrix_polar), stepped by the same fixed-step `refsim.integrators` steppers.
The configuration is the orientation only (the pivot holds the centre of mass on its sphere
exactly, for every formulation: x = anchor + R c), the velocity the world angular velocity.

Observes x (centres of mass, anchor + R c), v (w x R c), q, w (world), `orientation_defect`
(n,), and the extras `energy` () J (sum over bodies of 1/2 w . L - m g . x), `angular_momentum`
(n, 3) world L = I_p w ABOUT EACH PIVOT (not about the centre of mass as in the rigid group),
`det_defect` (n,) det R - 1.

Not symplectic: the step integrates the world angular velocity with the gyroscopic term
w x (I_p w) explicit (a Lie-group step of w, not of the momentum), so symplectic Euler and the
implicit midpoint rule are not symplectic maps here and a tumbling top's energy drifts
secularly. Only when w stays along a principal axis of I_p (a planar hinge) do they reduce to
their symplectic forms on the hinge angle. The settings declare `symplectic: False` for every
stepper, so tolerances read the non-symplectic bound.
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup
from refsim.integrators import get_integrator
from refsim.models.rigid_orientation import get_formulation
from refsim.models.rigid_pivot import PivotedRigidSystem
from refsim.scene.pivots import check_on_anchor
from refsim.scene.pivots import RigidPivots
from refsim.scene import RigidBodies

from ..stepped import SteppedSim
from .rigid import DEFAULT_FORMULATION, INTEGRATORS, VARIANTS, RigidSim

SYMPLECTIC_NOTE = ("not symplectic: w is stepped with the explicit gyroscopic term w x (I_p w) "
                   "in the world frame (not a momentum or Lie-Poisson step); symplectic only on "
                   "a planar hinge, where w stays along a principal axis of I_p")


class PivotSim(RigidSim):
    """A RigidSim whose system is `PivotedRigidSystem` (its settings and stages reused)."""

    def __init__(self, scene, dt, stepper, formulation):
        rigid, pivots, self.scene = scene.part(RigidBodies), scene.part(RigidPivots), scene
        check_on_anchor(pivots, rigid)
        order = np.argsort(pivots.body)  # every body has one pivot: sorted bodies = 0..n-1
        self.formulation = get_formulation(formulation)
        system = PivotedRigidSystem(rigid.mass, rigid.inertia, -pivots.body_point[order],
                                    pivots.anchor[order], scene.gravity, self.formulation)
        SteppedSim.__init__(self, dt, stepper, system, system.configuration(rigid.orientation),
                            np.array(rigid.angular_velocity, float))

    def stages(self):
        return ["pivot_gravity_torque"] + super().stages()[-3:]

    def _observe(self):
        x, w = self.coordinates()
        system = self.system
        return {"x": system.position(x), "v": system.com_velocity(x, w),
                "q": system.quaternion(x), "w": w,
                "orientation_defect": system.defect(x),
                "energy": float(np.sum(system.energy(x, w))),
                "angular_momentum": system.angular_momentum(x, w),
                "det_defect": self.formulation.det_defect(x)}

    def settings(self):
        base = super().settings()
        return {**base, "integrator": {**base["integrator"], "symplectic": False},
                "symplectic_note": SYMPLECTIC_NOTE,
                "gyroscopic_term": "explicit: w x (I_p w) about the pivot, at the stepper's "
                                   "stages",
                "pivot": "ball joint in generalized coordinates (orientation only): the "
                         "centre of mass stays on its sphere exactly, no constraint force"}


def _claims(scene) -> bool:
    """Scenes of rigid bodies and a RigidPivots part, nothing else (no contact model)."""
    return scene.part(RigidBodies) is not None and scene.part_kinds() == {"rigid", "rigid_pivots"} \
        and scene.contact is None


def _supports(engine, scene, integrator):
    if scene.dim != 3:
        return "refsim rigid bodies are 3D (quaternion or 3x3 orientation)"
    pivots, n = scene.part(RigidPivots), len(scene.part(RigidBodies))
    if len(pivots) != n or np.any(pivots.body >= n):
        return (f"refsim pivots need every rigid body pivoted ({n} bodies, pivots on "
                f"{sorted(pivots.body.tolist())}): free and pivoted bodies are not mixed")
    return None


def _formulations(engine, scene):
    return VARIANTS


def _build(engine, scene, dt, integrator, formulation):
    return PivotSim(scene, dt, get_integrator(integrator), formulation or DEFAULT_FORMULATION)


MODEL_GROUP = ModelGroup(name="pivots", build=_build, claims=_claims,
                         parts=frozenset({"rigid", "rigid_pivots"}),
                         features=frozenset({"rigid", "gravity", "pivots"}),
                         supports=_supports, formulations=_formulations, integrators=INTEGRATORS)
