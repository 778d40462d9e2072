"""MuJoCo's particle group: point masses without contacts, alone, on springs to fixed anchors
or on rods (hinges), with gravity and linear drag (adapters/mujoco_engine/__init__.py).

Each scene body becomes one MuJoCo body (`point_masses`): a free particle has 3 slide joints, a
mass on a spring one slide joint along the anchor-body line with joint stiffness, a mass on a
rod one hinge through the anchor (a generalized coordinate: its "constraint" is exactly 0).

The group claims every scene of moving particles without a contact model or walls (those are
group "spheres"), without grids (refused from the engine's table) and other than the exact
gravity-pairs scene (group "gravity_pairs"); a scene with a part MuJoCo lacks here
(lennard_jones, flocking, ...) is refused by the parts check with that part's name."""
from __future__ import annotations

from refsim.engine import ModelGroup
from refsim.scene import Grid, Joints, Particles, Springs, Walls

WHO = "mujoco adapter"  # how the reasons name this engine


def particle_scene(scene) -> bool:
    """Moving particles that neither the gravity-pairs group nor the grid refusal takes: the
    scenes of groups "particles" and "spheres"."""
    from .gravity_pairs import claims as gravity_pairs_claims
    return (scene.part(Particles) is not None and not scene.parts_of(Grid)
            and not gravity_pairs_claims(scene))


def claims(scene) -> bool:
    return particle_scene(scene) and scene.contact is None and scene.part(Walls) is None


def plans(scene) -> list:
    """One BodyPlan per body: a hinge for a rod body, a slide for a spring body, else 3
    slides; ValueError with the one-sentence reason when the scene cannot be faithful."""
    from refsim_adapters.common.hinges import rod_start_refusal

    from ..point_masses import hinge_plan, particle_plan, spring_plan
    springs = _springs_by_body(scene)
    joints = _joints_by_body(scene, springs)
    reason = rod_start_refusal(scene, WHO) if joints else None
    if reason:
        raise ValueError(reason)
    drag, out = scene.linear_drag, []
    for i, body in enumerate(scene.part(Particles).to_records()):
        if i in joints:
            out.append(hinge_plan(i, body, joints[i], drag))
        elif i in springs:
            out.append(spring_plan(i, body, springs[i], scene.gravity, drag))
        else:
            out.append(particle_plan(i, body, drag))
    return out


def _springs_by_body(scene) -> dict:
    from refsim_adapters.common.checks import body_to_body_springs
    reason = body_to_body_springs(scene, WHO, " (a joint spring needs a fixed anchor)")
    if reason:
        raise ValueError(reason)
    part, springs = scene.part(Springs), {}
    for s in (() if part is None else part.to_records()):
        if s.body in springs:
            raise ValueError("mujoco adapter: at most one spring per body (a slide-joint "
                             "spring moves along one line)")
        springs[s.body] = s
    return springs


def _joints_by_body(scene, springs) -> dict:
    part, joints = scene.part(Joints), {}
    for j in (() if part is None else part.to_records()):
        if j.body in joints or j.body in springs:
            raise ValueError("mujoco adapter: a body may carry one rod or one spring, not both "
                             "or several")
        joints[j.body] = j
    return joints


def supports(engine, scene, integrator):
    try:
        plans(scene)
    except ValueError as exc:
        return str(exc)
    return None


def build(engine, scene, dt, integrator, formulation):
    from ..sim import MujocoSim
    joints = scene.part(Joints)
    return MujocoSim(scene, plans(scene), dt, integrator,
                     rods=0 if joints is None else len(joints))


MODEL_GROUP = ModelGroup(
    name="particles", build=build, claims=claims,
    parts=frozenset({"particles", "springs", "joints"}),
    features=frozenset({"gravity", "springs", "joints", "drag"}),
    supports=supports)
