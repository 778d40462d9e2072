"""The in-house engine's particles group: point masses under gravity, drag and springs, with
rods in one of three formulations: `generalized` (one angle per rod, `hinges.HingeSim`), `kkt`
(maximal coordinates, Lagrange multipliers, Baumgarte stabilisation) and `penalty` (the rod as
a stiff spring), both `particles.ParticleSim`. Claims scenes of particles with springs, rods
or walls beside them and no contact model (walls then only bound the scene: nothing collides).
"""
from __future__ import annotations

from functools import partial

from refsim.engine import ModelGroup
from refsim.integrators import get_integrator
from refsim.scene import Joints, Particles, Springs

from ...common.checks import rods_per_body, springs_on_rod_bodies
from ...common.hinges import rod_length_errors

JOINT_FORMULATIONS = ("generalized", "kkt", "penalty")
KINDS = frozenset({"particles", "springs", "joints", "walls"})

# Baumgarte rate w = 5 w0 (w0 = sqrt(|g|/L), or 1 rad/s without gravity): a fixed physical
# rate keeps every stepper's order (a rate tied to 1/dt drops RK4 to second order), and
# w dt stays far inside every explicit stepper's stability region for the dts used here.
BAUMGARTE_RATIO = 5.0
# Penalty rod stiffness: rod frequency / pendulum frequency; the rod stretches by about
# (w0 / w_rod)^2 L, so 100 gives a 1e-4 relative length error.
PENALTY_RATIO = 100.0


def claims(scene) -> bool:
    kinds = scene.part_kinds()
    return scene.contact is None and "particles" in kinds and kinds <= KINDS


def _formulations(engine, scene):
    return JOINT_FORMULATIONS if scene.part(Joints) is not None else ("",)


def _supports(engine, scene, integrator):
    if scene.part(Joints) is None:
        return None
    return (rods_per_body(scene, "refsim joints", every_body=True)
            or springs_on_rod_bodies(scene, "refsim joints"))


def _build(engine, scene, dt, integrator, formulation):
    from ..hinges import HingeSim
    from ..particles import ParticleSim, baumgarte_rods, penalty_rod_springs
    stepper = get_integrator(integrator)
    if formulation == "generalized":
        return HingeSim(scene, dt, stepper)
    bodies, given, joints = (scene.part(c) for c in (Particles, Springs, Joints))
    springs = list(given.to_records()) if given is not None else []
    rods, constraint, extra = None, None, {}
    if joints is not None:  # rods: penalty springs or kkt constraints, their errors observed
        constraint = partial(rod_length_errors, scene)
        if formulation == "penalty":
            rod_springs = penalty_rod_springs(joints, bodies.mass, scene.gravity, PENALTY_RATIO)
            springs += rod_springs
            extra = {"penalty_stiffness": [s.stiffness for s in rod_springs],
                     "penalty_ratio": PENALTY_RATIO}
        else:
            rods = baumgarte_rods(joints, scene.gravity, BAUMGARTE_RATIO)
            extra = {"baumgarte_w": rods.baumgarte, "baumgarte_w_dt": rods.baumgarte * dt}
    return ParticleSim(dt, stepper, bodies, scene.gravity, scene.linear_drag, formulation,
                       springs, rods, constraint, extra)


MODEL_GROUP = ModelGroup(
    name="particles", claims=claims, parts=KINDS,
    features=frozenset({"gravity", "springs", "joints", "drag", "walls"}),
    supports=_supports, formulations=_formulations, build=_build)
