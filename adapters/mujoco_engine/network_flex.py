"""Formulation "flex" of MuJoCo's spring-network group: a HAIR (a chain with bending hinges)
as a 1-D `flexcomp` discrete elastic rod (mujoco 4.0.0), stretch edges as spatial tendons.

Which networks: one open chain, edges (i, i+1) for i = 0..n-2, a hinge (i-1, i, i+1) at EVERY
interior node with rest angle 0 (straight), no dihedrals, rest lengths > 0 and one bending
rigidity E I for the whole rod (below). Anything else is refused with its reason.

MuJoCo's rod bending (XML reference, flex/elasticity, 1D; measured in
tests/engines/mujoco/test_mujoco_flex_network.py to round-off): each interior vertex stores
    U_v = k |kb|^2,  k = E I / (l0 + l1),  |kb| = 2 tan(phi / 2)
with l0, l1 the REFERENCE (qpos0) lengths of its two edges, phi the turning angle and kb the
discrete curvature binormal 2 e0 x e1 / (|e0| |e1| + e0.e1) of Bergou et al. (2008); I = pi r^4 / 4
for the default circular section of radius r. refsim's hinge stores 1/2 k_b phi^2. Matching the
leading term (2 tan(phi/2))^2 = phi^2 (1 + phi^2 / 6 + ...):
    k_b = 2 E I / (l0 + l1)   <=>   E I = k_b (l0 + l1) / 2,   young E = 2 k_b (l0 + l1) / (pi r^4)
so one flex (one young, one radius) holds a chain only where k_b (l0 + l1) / 2 is the same at
every hinge (e.g. k_b = E I / l on a uniform chain). The remaining difference is the bending
MEASURE: MuJoCo's moment dU/dphi = k_b 2 tan(phi/2) / cos^2(phi/2) = k_b phi (1 + phi^2/3 + ...)
against refsim's k_b phi, a relative excess phi^2 / 3 (6.7e-4 at 0.045 rad).

The rest of the mapping:
- reference configuration (qpos0): the STRAIGHT chain through node 0 along node 1 - node 0 with
  the edges' rest lengths (MuJoCo keeps as reference curvature any vertex bent > 1e-4 rad in
  qpos0, so the rest shape must be built straight); pinned nodes must lie on it (checked); the
  initial positions and velocities are then set through qpos / qvel;
- pinned nodes: `<pin id=...>` (vertices attached to the world body); nodes 0 and 1 pinned
  clamp the first edge (MuJoCo: its material frame fixed, no twist joint);
- torsion: refsim's hinge has none, so `shear` (G) is set to young x 1e-12 (MuJoCo needs G > 0
  to override its isotropic G = E / (2 (1 + nu))): torsional stiffness 1e-12 of the bending
  one. flexcomp still adds a per-edge twist hinge joint (a body of mass 1e-9 with the edge's
  polar inertia): with no torque on it in planar motion it stays at 0 (measured);
- Rayleigh damping 0; flex edge stiffness and damping 0 (MuJoCo: explicit only, refused by
  `discrete`): stretching is the tendon formulation's, spatial tendons with the edge's k, L0,
  c between sites on the vertex bodies (exactly the in-house stretch model);
- masses: every free vertex body gets the node's mass and inertia POINT_INERTIA (edited in the
  MjSpec after flexcomp expands it: flexcomp alone spreads one mass uniformly); the air drag
  -c_air v is a fixed tendon per slide joint (coefficient 1, damping c_air: force -c_air v_axis
  exactly), because MuJoCo refuses joint damping on flex vertex bodies; collisions off.
"""
from __future__ import annotations

import numpy as np

from refsim.scene import SpringNetwork

from .mjcf import xml_floats
from .network_mjcf import AXES, SOLVER_ITERATIONS, SOLVER_TOLERANCE, kept_edges
from .point_masses import POINT_INERTIA

WHO = "mujoco adapter, formulation flex"
FLEX_NAME = "hair"
SHEAR_RATIO = 1e-12   # G / E: refsim's hinge has no torsion (module doc)
REST_ANGLE_MAX = 1e-10  # rad: a straight chain's computed initial angles are ~1e-16
RADIUS_FRACTION = 0.1   # rod radius / shortest rest length: enters only I (young follows it),
#                         the twist inertia and collisions (off)
EI_RTOL = 1e-12         # one E I per flex: k_b (l0 + l1) / 2 equal to round-off of 4 products


def _chain_reason(net) -> str | None:
    n = len(net)
    edges = np.sort(net.edges, axis=1)
    chain = np.c_[np.arange(n - 1), np.arange(1, n)]
    if n < 3 or len(edges) != n - 1 or not np.array_equal(edges, chain):
        return (f"{WHO}: the network must be one open chain with edges (i, i+1) in node order "
                "(a 1-D flexcomp is a polyline)")
    hinges = net.hinges.copy()
    flip = hinges[:, 0] > hinges[:, 2]
    hinges[flip] = hinges[flip][:, ::-1]
    wanted = np.c_[np.arange(n - 2), np.arange(1, n - 1), np.arange(2, n)]
    if not np.array_equal(hinges, wanted):
        return (f"{WHO}: the rod bends at EVERY interior vertex, so the network needs exactly "
                "the hinges (i-1, i, i+1), i = 1..n-2, in node order")
    return None


def flex_reason(net) -> str | None:
    """None when `net` is a hair that one 1-D flexcomp rod represents, else the reason."""
    if len(net.dihedrals):
        return f"{WHO}: dihedrals belong to 2-D flexes; a rod has hinges only"
    reason = _chain_reason(net)
    if reason:
        return reason
    if np.any(np.abs(net.hinge_rest_angle) > REST_ANGLE_MAX):
        return (f"{WHO}: hinge rest angles must be 0 (straight rod, |theta0| <= "
                f"{REST_ANGLE_MAX:g} rad); got up to {np.abs(net.hinge_rest_angle).max():g}")
    if np.any(net.rest_length <= 0):
        return f"{WHO}: rest lengths must be > 0 (MuJoCo refuses a zero-length rod edge)"
    ei = bending_rigidity(net)
    if np.ptp(ei) > EI_RTOL * ei.max():
        return (f"{WHO}: one young modulus per flex needs k_b (l0 + l1) / 2 equal at every "
                f"hinge; got {ei.min():g}..{ei.max():g} N m^2")
    gap = np.abs(rest_layout(net) - net.positions)[net.pinned].max(initial=0.0)
    if gap > _layout_tolerance(net):
        return (f"{WHO}: pinned nodes must lie on the straight rest chain through node 0 "
                f"along node 1 (the flex's reference configuration); off by {gap:g} m")
    return None


def rest_lengths(net) -> np.ndarray:
    """(n-1,) rest length of edge (i, i+1)."""
    order = np.argsort(np.min(net.edges, axis=1))
    return np.asarray(net.rest_length, float)[order]


def bending_rigidity(net) -> np.ndarray:
    """E I = k_b (l0 + l1) / 2 per hinge (module doc), in hinge order of node i = 1..n-2."""
    lengths = rest_lengths(net)
    order = np.argsort(net.hinges[:, 1])
    return np.asarray(net.hinge_stiffness, float)[order] * (lengths[:-1] + lengths[1:]) / 2


def rest_layout(net) -> np.ndarray:
    """(n, 3) the straight reference chain: node 0, then the rest lengths along node 1 - node 0."""
    x = np.asarray(net.positions, float)
    axis = (x[1] - x[0]) / np.linalg.norm(x[1] - x[0])
    arc = np.concatenate([[0.0], np.cumsum(rest_lengths(net))])
    return x[0] + arc[:, None] * axis


def _layout_tolerance(net) -> float:
    """Round-off of the cumulative sum and the axis: 4 n eps times the chain's extent."""
    extent = np.abs(net.positions).max() + np.sum(net.rest_length)
    return 4 * len(net) * np.finfo(float).eps * extent


def rod_parameters(net) -> dict:
    """radius r, young E = E I / (pi r^4 / 4), shear G = 1e-12 E (module doc)."""
    radius = RADIUS_FRACTION * float(np.min(net.rest_length))
    second_moment = np.pi * radius ** 4 / 4
    young = float(bending_rigidity(net).mean()) / second_moment
    return {"radius": radius, "second_moment": second_moment, "young": young,
            "shear": SHEAR_RATIO * young, "poisson": 0.0, "rayleigh_damping": 0.0}


def _flex_xml(scene, dt, integrator_xml, net, rod) -> str:
    points = xml_floats(rest_layout(net).ravel())
    pins = " ".join(str(int(i)) for i in np.sort(net.pinned))
    pin = f'<pin id="{pins}"/>' if len(net.pinned) else ""
    return (f'<mujoco model="refsim_network_flex"><compiler inertiafromgeom="false"/>'
            f'<option timestep="{xml_floats(dt)}" gravity="{xml_floats(scene.gravity)}" '
            f'integrator="{integrator_xml}" density="0" viscosity="0" wind="0 0 0" '
            f'solver="Newton" tolerance="{SOLVER_TOLERANCE!r}" '
            f'iterations="{SOLVER_ITERATIONS}">'
            f'<flag contact="disable" eulerdamp="disable" autoreset="disable"/></option>'
            f'<worldbody><flexcomp name="{FLEX_NAME}" type="direct" dim="1" point="{points}" '
            f'radius="{rod["radius"]!r}" mass="{float(np.sum(net.masses))!r}">{pin}'
            f'<elasticity young="{rod["young"]!r}" poisson="0" shear="{rod["shear"]!r}" '
            f'damping="0"/><edge stiffness="0" damping="0"/>'
            f'<contact contype="0" conaffinity="0"/></flexcomp></worldbody></mujoco>')


def _vertex_bodies(spec, net, free):
    """Node mass, point inertia, a site and joint names n<i>_x/y/z on every free vertex body;
    a world site at every pinned node (build time: one call per node)."""
    for i in np.flatnonzero(free):
        body = spec.body(f"{FLEX_NAME}_{i}")
        body.mass, body.inertia = float(net.masses[i]), [POINT_INERTIA] * 3
        body.explicitinertial = True
        for joint, (axis, _) in zip(body.joints, AXES):
            joint.name = f"n{i}_{axis}"
        body.add_site(name=f"s{i}", pos=[0.0, 0.0, 0.0])
    for i in np.flatnonzero(~free):
        spec.worldbody.add_site(name=f"s{i}", pos=list(map(float, net.positions[i])))


def _tendons(spec, net, free):
    for k in kept_edges(net, free):
        i, j = map(int, net.edges[k])
        rest = float(net.rest_length[k])
        tendon = spec.add_tendon(name=f"e{k}", stiffness=float(net.stiffness[k]),
                                 springlength=[rest, rest], damping=float(net.damping[k]))
        tendon.wrap_site(f"s{i}")
        tendon.wrap_site(f"s{j}")


def _drag_tendons(spec, free, drag: float):
    """Air drag -c_air v: a fixed tendon per slide (coefficient 1) with damping c_air, as MuJoCo
    refuses joint damping on flex vertex bodies ("use flex elasticity or edge damping
    instead"); none when c_air = 0."""
    if drag == 0:
        return
    for i in np.flatnonzero(free):
        for axis, _ in AXES:
            spec.add_tendon(name=f"drag{i}_{axis}", damping=drag).wrap_joint(f"n{i}_{axis}", 1.0)


def flex_model(scene, dt, integrator_xml, free):
    """Compiled MjModel of formulation "flex" and the rod parameters used."""
    import mujoco
    net = scene.parts_of(SpringNetwork)[0]
    rod = rod_parameters(net)
    spec = mujoco.MjSpec.from_string(_flex_xml(scene, dt, integrator_xml, net, rod))
    _vertex_bodies(spec, net, free)
    _tendons(spec, net, free)
    _drag_tendons(spec, free, float(scene.linear_drag))
    return spec.compile(), rod


def vertex_indices(model, free) -> tuple[np.ndarray, np.ndarray]:
    """(n_free, 3) qpos and qvel addresses of the x, y, z slides of each free vertex body."""
    import mujoco
    qpos, dofs = [], []
    for i in np.flatnonzero(free):
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"{FLEX_NAME}_{i}")
        joints = np.flatnonzero(model.jnt_bodyid == body)
        qpos.append(model.jnt_qposadr[joints])
        dofs.append(model.jnt_dofadr[joints])
    return np.array(qpos, int).reshape(-1, 3), np.array(dofs, int).reshape(-1, 3)
