"""ParticleSim: free particles with gravity, drag and springs in Cartesian coordinates; rods
as maximal coordinates with Lagrange multipliers (`kkt`) or as stiff springs (`penalty`)."""
from __future__ import annotations

import numpy as np

from refsim.models.forces import SpringSet
from refsim.models.joints import RodSet
from refsim.models.system import ParticleSystem
from refsim.scene import Joints, Particles, Spring, Springs

from ..common.hinges import rod_length_errors
from .stepped import SteppedSim

FORMULATIONS = {"": "cartesian",
                "kkt": "maximal coordinates, Lagrange multipliers (KKT by its Schur "
                       "complement) + Baumgarte",
                "penalty": "maximal coordinates, penalty spring rod"}


class ParticleSim(SteppedSim):
    def __init__(self, scene, dt, stepper, variant, penalty_ratio, baumgarte_ratio):
        self.variant, self.scene = variant, scene
        bodies, given, joints = (scene.part(c) for c in (Particles, Springs, Joints))
        self.joints = joints
        springs, rods, self.extra = list(given.to_records() if given else ()), None, {}
        if joints is not None and variant == "penalty":
            rod_springs = penalty_rod_springs(scene, penalty_ratio)
            springs += rod_springs
            self.extra = {"penalty_stiffness": [s.stiffness for s in rod_springs],
                          "penalty_ratio": penalty_ratio}
        elif joints is not None:
            rods = baumgarte_rods(scene, baumgarte_ratio)
            self.extra = {"baumgarte_w": rods.baumgarte, "baumgarte_w_dt": rods.baumgarte * dt}
        spring_set = SpringSet.from_scene(springs) if springs else None
        system = ParticleSystem(bodies.mass, scene.gravity, scene.linear_drag, spring_set, rods)
        super().__init__(dt, stepper, system, bodies.position.reshape(-1),
                         bodies.velocity.reshape(-1))

    def stages(self):
        stages = self.system.stages()
        if self.variant == "penalty":
            stages = [s if s != "springs" else "penalty_rods" for s in stages]
        return stages + [f"integrate:{self.stepper.name}"]

    def _observe(self):
        x, v = self.coordinates()
        out = {"x": x.reshape(-1, 3), "v": v.reshape(-1, 3)}
        if self.joints is not None:
            out["constraint"] = rod_length_errors(self.scene, out["x"])
        return out

    def settings(self):
        out = {**self.base_settings(), "formulation": FORMULATIONS[self.variant], **self.extra}
        if self.variant == "kkt":
            # a symplectic stepper on the Baumgarte-stabilised index-1 ODE is not a symplectic
            # integrator of the constrained system (that would be RATTLE): declare it so
            out["integrator"] = {**out["integrator"], "symplectic": False,
                                 "note": "not symplectic on the index-1 KKT formulation"}
        return out


def penalty_rod_springs(scene, penalty_ratio):
    """Each rod as a spring from its anchor, stiffness m (penalty_ratio w0)^2 with the
    pendulum frequency w0 = sqrt(|g| / L) (|g| floored at 1e-12)."""
    g = np.linalg.norm(scene.gravity)
    springs, masses = [], scene.part(Particles).mass
    for joint in scene.part(Joints).to_records():
        w0 = np.sqrt(max(g, 1e-12) / joint.length)
        stiffness = masses[joint.body] * (penalty_ratio * w0) ** 2
        springs.append(Spring(body=joint.body, stiffness=stiffness, rest_length=joint.length,
                              anchor=joint.anchor))
    return springs


def baumgarte_rods(scene, baumgarte_ratio):
    """The rods as a RodSet with Baumgarte rate baumgarte_ratio x sqrt(|g| / L_min) (x 1 rad/s
    without gravity)."""
    joints = scene.part(Joints).to_records()
    lengths = np.array([j.length for j in joints])
    g = np.linalg.norm(scene.gravity)
    rate = baumgarte_ratio * (np.sqrt(g / lengths.min()) if g > 0 else 1.0)
    return RodSet(body=np.array([j.body for j in joints]),
                  anchor=np.array([j.anchor for j in joints]),
                  length=lengths, baumgarte=rate)

