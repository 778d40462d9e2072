"""ParticleSim: free particles with gravity, drag and springs in Cartesian coordinates; rods
as maximal coordinates with Lagrange multipliers (`kkt`) or as stiff springs (`penalty`).

A helper of the particles group (groups/particles.py): the group reads the scene and decides
what the sim holds (springs, rods, the constraint it observes); the sim takes those as
arguments and never looks at a scene."""
from __future__ import annotations

import numpy as np

from refsim.models.forces import SpringSet
from refsim.models.joints import RodSet
from refsim.models.system import ParticleSystem
from refsim.scene import Spring

from .stepped import SteppedSim

FORMULATIONS = {"": "cartesian",
                "kkt": "maximal coordinates, Lagrange multipliers (KKT by its Schur "
                       "complement) + Baumgarte",
                "penalty": "maximal coordinates, penalty spring rod"}


class ParticleSim(SteppedSim):
    """The bodies of `particles` (a Particles part) under `gravity` (3,), linear `drag`
    (N s/m) and `springs` (Spring records, penalty rods included), held by `rods` (a RodSet:
    the kkt formulation) when given. `constraint(x)`, when given, is observed as
    "constraint" (the rods' length errors); `extra` joins the settings (the formulation's own
    parameters)."""

    def __init__(self, dt, stepper, particles, gravity, drag, formulation="", springs=(),
                 rods=None, constraint=None, extra=None):
        self.formulation, self.constraint = formulation, constraint
        self.extra = dict(extra or {})
        spring_set = SpringSet.from_scene(springs) if springs else None
        system = ParticleSystem(particles.mass, gravity, drag, spring_set, rods)
        super().__init__(dt, stepper, system, particles.position.reshape(-1),
                         particles.velocity.reshape(-1))

    def stages(self):
        stages = self.system.stages()
        if self.formulation == "penalty":
            stages = [s if s != "springs" else "penalty_rods" for s in stages]
        return stages + [f"integrate:{self.stepper.name}"]

    def _observe(self):
        x, v = self.coordinates()
        out = {"x": x.reshape(-1, 3), "v": v.reshape(-1, 3)}
        if self.constraint is not None:
            out["constraint"] = self.constraint(out["x"])
        return out

    def settings(self):
        out = {**self.base_settings(), "formulation": FORMULATIONS[self.formulation],
               **self.extra}
        if self.formulation == "kkt":
            # a symplectic stepper on the Baumgarte-stabilised index-1 ODE is not a symplectic
            # integrator of the constrained system (that would be RATTLE): declare it so
            out["integrator"] = {**out["integrator"], "symplectic": False,
                                 "note": "not symplectic on the index-1 KKT formulation"}
        return out


def penalty_rod_springs(joints, masses, gravity, penalty_ratio):
    """Each rod of `joints` (a Joints part) as a spring from its anchor, stiffness
    m (penalty_ratio w0)^2 with the pendulum frequency w0 = sqrt(|g| / L) (|g| floored at
    1e-12)."""
    g = np.linalg.norm(gravity)
    springs = []
    for joint in joints.to_records():
        w0 = np.sqrt(max(g, 1e-12) / joint.length)
        stiffness = masses[joint.body] * (penalty_ratio * w0) ** 2
        springs.append(Spring(body=joint.body, stiffness=stiffness, rest_length=joint.length,
                              anchor=joint.anchor))
    return springs


def baumgarte_rods(joints, gravity, baumgarte_ratio):
    """The rods of `joints` (a Joints part) as a RodSet with Baumgarte rate baumgarte_ratio x
    sqrt(|g| / L_min) (x 1 rad/s without gravity)."""
    records = joints.to_records()
    lengths = np.array([j.length for j in records])
    g = np.linalg.norm(gravity)
    rate = baumgarte_ratio * (np.sqrt(g / lengths.min()) if g > 0 else 1.0)
    return RodSet(body=np.array([j.body for j in records]),
                  anchor=np.array([j.anchor for j in records]),
                  length=lengths, baumgarte=rate)
