"""The MJCF of a spring network, formulation "tendon" (mujoco 4.0.0).

- every free node: a world child body at its initial position with an explicit point-mass
  `<inertial>` (the node's mass) and three slide joints x, y, z (damping = the scene's air drag
  c_air, armature 0, no stiffness): its mass matrix is m I exactly, qpos = displacement from the
  initial position, qvel = the node's velocity; a site at the body origin;
- every pinned node: a site on the world body at its position;
- every stretch edge with a free end: a spatial tendon between the two sites with `stiffness`
  k, `springlength` L0 and `damping` c (MuJoCo: force -k (L - L0) - c dL/dt along the tendon,
  i.e. f_i = -[k (|d| - L0) + c (v_i - v_j).u] u, the in-house stretch model); an edge between
  two pinned nodes exerts nothing and is left out (as in refsim.models.spring_network).
Options: explicit timestep and gravity, no fluid forces, contacts, eulerdamp and autoreset
disabled; the Newton solver with a tight tolerance (used only by `discrete`, whose step is
solved in the effective metric M + h D + h^2 K).
"""
from __future__ import annotations

import numpy as np

from refsim.scene import SpringNetwork

from .mjcf import xml_floats
from .point_masses import POINT_INERTIA

SOLVER_TOLERANCE = 1e-14  # Newton's relative tolerance (discrete's smooth solve): round-off
SOLVER_ITERATIONS = 100
AXES = (("x", "1 0 0"), ("y", "0 1 0"), ("z", "0 0 1"))


def kept_edges(net, free: np.ndarray) -> np.ndarray:
    """Row indices of the edges with at least one free end (the others exert nothing)."""
    return np.flatnonzero(free[net.edges[:, 0]] | free[net.edges[:, 1]])


def _node_xml(i: int, position, mass: float, drag: float) -> str:
    joints = "".join(f'<joint name="n{i}_{a}" type="slide" axis="{axis}" '
                     f'damping="{drag!r}" armature="0" stiffness="0"/>' for a, axis in AXES)
    return (f'<body name="n{i}" pos="{xml_floats(position)}">'
            f'<inertial pos="0 0 0" mass="{mass!r}" '
            f'diaginertia="{xml_floats([POINT_INERTIA] * 3)}"/>{joints}'
            f'<site name="s{i}" pos="0 0 0"/></body>')


def _tendon_xml(k: int, i: int, j: int, stiffness: float, rest: float, damping: float) -> str:
    return (f'<spatial name="e{k}" stiffness="{stiffness!r}" springlength="{rest!r}" '
            f'damping="{damping!r}" armature="0" frictionloss="0">'
            f'<site site="s{i}"/><site site="s{j}"/></spatial>')


def network_xml(scene, dt: float, integrator_xml: str, free: np.ndarray) -> str:
    """MJCF of formulation "tendon" for the scene's network (build time only: one string per
    node and per edge)."""
    net = scene.parts_of(SpringNetwork)[0]
    x, m, drag = net.positions, net.masses, float(scene.linear_drag)
    nodes = "".join(_node_xml(i, x[i], float(m[i]), drag) for i in np.flatnonzero(free))
    pins = "".join(f'<site name="s{i}" pos="{xml_floats(x[i])}"/>'
                   for i in np.flatnonzero(~free))
    edges = kept_edges(net, free)
    tendons = "".join(_tendon_xml(k, *net.edges[k], float(net.stiffness[k]),
                                  float(net.rest_length[k]), float(net.damping[k]))
                      for k in edges)
    return (f'<mujoco model="refsim_network"><compiler inertiafromgeom="false"/>'
            f'<option timestep="{xml_floats(dt)}" gravity="{xml_floats(scene.gravity)}" '
            f'integrator="{integrator_xml}" density="0" viscosity="0" wind="0 0 0" '
            f'solver="Newton" tolerance="{SOLVER_TOLERANCE!r}" '
            f'iterations="{SOLVER_ITERATIONS}">'
            f'<flag contact="disable" eulerdamp="disable" autoreset="disable"/></option>'
            f'<worldbody>{pins}{nodes}</worldbody><tendon>{tendons}</tendon></mujoco>')
