"""The MJCF text of a scene plan: explicit timestep and gravity, no fluid forces, eulerdamp and
autoreset off, contacts off unless a ContactSetup describes them."""
from __future__ import annotations

import numpy as np

from .body_plan import BodyPlan
from .contact_params import SOLVER_ITERATIONS, SOLVER_TOLERANCE
from .methods import Method
from .point_masses import POINT_INERTIA


def xml_floats(values) -> str:
    """Numbers as MJCF attribute text: space-separated reprs (exact float64 round trip)."""
    return " ".join(repr(float(c)) for c in np.atleast_1d(values))


def _slide_joints_xml(plan: BodyPlan) -> str:
    return "".join(f'<joint name="b{plan.index}_{n}" type="slide" axis="{a}" '
                   f'damping="{xml_floats(plan.damping)}"/>'
                   for n, a in (("x", "1 0 0"), ("y", "0 1 0"), ("z", "0 0 1")))


def _spring_joint_xml(plan: BodyPlan) -> str:
    return (f'<joint name="b{plan.index}_spring" type="slide" axis="{xml_floats(plan.axis)}" '
            f'stiffness="{xml_floats(plan.stiffness)}" '
            f'springref="{xml_floats(plan.springref)}" damping="{xml_floats(plan.damping)}"/>')


def _hinge_joint_xml(plan: BodyPlan) -> str:
    return (f'<joint name="b{plan.index}_hinge" type="hinge" '
            f'pos="{xml_floats(plan.joint_pos)}" axis="{xml_floats(plan.axis)}" '
            f'damping="{xml_floats(plan.damping)}"/>')


def _sphere_xml(plan: BodyPlan) -> str:
    return (f'<freejoint name="b{plan.index}_free"/>'
            f'<geom name="s{plan.index}" type="sphere" size="{xml_floats(plan.radius)}"/>')


_JOINTS_XML = {"particle": _slide_joints_xml, "spring": _spring_joint_xml,
               "hinge": _hinge_joint_xml, "sphere": _sphere_xml}


def body_xml(plan: BodyPlan) -> str:
    """One <body> at the scene's initial position: explicit <inertial>, then its joints."""
    inertia = plan.inertia if plan.kind == "sphere" else POINT_INERTIA
    inertial = (f'<inertial pos="0 0 0" mass="{xml_floats(plan.mass)}" '
                f'diaginertia="{xml_floats([inertia] * 3)}"/>')
    joints = _JOINTS_XML[plan.kind](plan)
    return (f'<body name="b{plan.index}" pos="{xml_floats(plan.position)}">{inertial}{joints}'
            f'</body>')


def scene_xml(scene, plans, dt: float, method: Method, contact=None) -> str:
    """MJCF: explicit timestep and gravity, no fluid forces, eulerdamp/autoreset off; contacts
    off unless `contact` (a ContactSetup) describes them."""
    bodies = "".join(body_xml(p) for p in plans)
    flags = 'eulerdamp="disable" autoreset="disable"'
    extra, default, walls, pairs = "", "", "", ""
    if contact is None:
        flags = 'contact="disable" ' + flags
    else:
        extra = (f' cone="elliptic" solver="Newton" iterations="{SOLVER_ITERATIONS}" '
                 f'tolerance="{SOLVER_TOLERANCE}" impratio="1"')
        default, walls, pairs = contact.default_xml(), contact.walls_xml(), contact.pairs_xml()
    return (f'<mujoco model="refsim"><compiler inertiafromgeom="false"/>'
            f'<option timestep="{xml_floats(dt)}" gravity="{xml_floats(scene.gravity)}" '
            f'integrator="{method.xml}" density="0" viscosity="0" wind="0 0 0"{extra}>'
            f'<flag {flags}/></option>{default}<worldbody>{walls}{bodies}</worldbody>'
            f'{pairs}</mujoco>')
