"""A `SpringNetwork` as pybullet's own mass-spring soft body (the deformable world), and the
reasons a network cannot be one.

What pybullet 3.2.7 does, read in bullet3 (src/BulletSoftBody: btDeformableMassSpringForce.h,
btDeformableBodySolver.cpp, btDeformableBackwardEulerObjective.cpp, btSoftBody.cpp;
examples/SharedMemory/PhysicsServerCommandProcessor.cpp) and measured here:
- bending springs: the server ignores `useBendingSprings`; any springBendingStiffness != 0
  (default 0.1) adds links between nodes two links apart (measured: a 6x6 cloth off by 1.2e-3 m
  at 0.3 s): the adapter passes 0.
- links: the unique edges of the .obj's triangles (btSoftBodyHelpers::CreateFromTriMesh), one
  node per vertex in file order. An edge in no triangle (a rope, a structural-only grid) is
  refused: as a degenerate triangle (i, j, j) it crashed pybullet 3.2.7 (double free, measured).
- stretch force per link: k (d - r d/|d|), k = springElasticStiffness in N/m per link (not
  scaled by rest length), the same k on every link; damping c ((v2 - v1).u) u along the link
  (springDampingAllDirections = 0), the same c on every link.
- rest lengths r: reset from the node positions at the first stepSimulation (updateConstants
  runs once a flag set at creation and by every anchor is up). The adapter puts the nodes at
  the rest geometry, takes one capture step of CAPTURE_DT with gravity off, then puts them at
  the scene's positions (resetMeshData). The .obj's vertices are read as float32 by tinyobj;
  the reset positions are float64.
- masses: loadSoftBody's `mass` is spread evenly (setTotalMass: mass / n per node); a world
  anchor (createSoftBodyAnchor(body, node, -1, -1)) sets the node's mass to 0: pinned exactly.
- step (setImplicit(false)): v* = v + h (gravity + elastic forces at x_n) / m; then the damping
  alone implicitly, M (v' - v*) = h f_damp(v'), by conjugate residual (absolute tolerance 1e-8
  on the preconditioned residual, at most 300 iterations); x' = x + h v'. Without damping this
  is symplectic Euler exactly; with damping it is IMEX (damping backward Euler).
- clamps: |v| <= (bounding-box diagonal) / h per node, before the drift; each velocity
  component <= m_maxDisplacement / h = 1000 m / h.
- sleeping: a body whose fastest node stays below 0.04 m/s for 2 s is frozen.
- no node velocities through the Python API (getMeshData's velocity flag is not reachable and
  resetMeshData writes positions only): v is observed as (x_n - x_{n-1}) / h, which is the
  stepper's own v_n (x_n = x_{n-1} + h v_n) up to round-off |x| eps / h.
- no linear drag: the deformable world ignores applyExternalForce's node forces (m_f is not
  read by the deformable solver) and btSoftBody's `drag` is not exposed.
"""
from __future__ import annotations

import os
import tempfile

import numpy as np
import scipy.sparse as sp

from refsim.scene import SpringNetwork

CAPTURE_DT = 1e-9  # s: the rest-length capture step (forces are ~0 there; gravity is off)
MAX_DISPLACEMENT = 1000.0  # m: btSoftBodyWorldInfo::m_maxDisplacement (per-component clamp)
SLEEP_SPEED, SLEEP_TIME = 0.04, 2.0  # m/s, s: btSoftBody m_sleepingThreshold, gDeactivationTime
CR_TOLERANCE, CR_MAX_ITERATIONS = 1e-8, 300
UNIFORM_RTOL = 1e-12  # relative spread allowed in "one value for every edge": round-off only


def _spread(values) -> float:
    values = np.asarray(values, float)
    scale = max(float(np.abs(values).max()), 1e-300) if values.size else 1.0
    return float(values.max() - values.min()) / scale if values.size else 0.0


def rest_scale(net) -> float | None:
    """s >= 0 with rest_length = s * initial length on every edge, else None."""
    x = net.positions
    initial = np.linalg.norm(x[net.edges[:, 0]] - x[net.edges[:, 1]], axis=1)
    if np.any(initial == 0):
        return None
    ratio = net.rest_length / initial
    return float(ratio.mean()) if _spread(ratio) <= UNIFORM_RTOL or not ratio.any() else None


def softbody_reason(scene) -> str | None:
    """Why pybullet's mass-spring soft body cannot be this network, or None."""
    net = scene.parts_of(SpringNetwork)[0]
    who = "pybullet softbody"
    if len(net.hinges) or len(net.dihedrals):
        return (f"{who}: no angle springs (its 'bending springs' are stretch links between nodes "
                "two links apart), got hinges or dihedrals")
    if scene.linear_drag > 0:
        return (f"{who}: no linear air drag (the deformable world ignores applyExternalForce on "
                f"nodes and does not expose btSoftBody's drag), got linear_drag "
                f"{scene.linear_drag}")
    if np.any(net.velocities != 0):
        return f"{who}: node velocities cannot be set (resetMeshData writes positions only)"
    free = np.ones(len(net), bool)
    free[net.pinned] = False
    for name, values in (("stiffness", net.stiffness), ("damping", net.damping),
                         ("masses of the free nodes", net.masses[free])):
        if _spread(values) > UNIFORM_RTOL:
            return f"{who}: one value for the whole body, got different {name}"
    if rest_scale(net) is None:
        return (f"{who}: rest lengths come from node positions at the first step, so they must "
                "be a scaled copy (s >= 0) of the initial edge lengths")
    return _topology_reason(net, who)


def _topology_reason(net, who) -> str | None:
    pairs = np.sort(net.edges, axis=1)
    if np.any(pairs[:, 0] == pairs[:, 1]):
        return f"{who}: an edge joins a node to itself"
    if len(np.unique(pairs, axis=0)) != len(pairs):
        return f"{who}: duplicate edges (the mesh holds each link once)"
    if len(np.unique(pairs)) != len(net):
        return f"{who}: every node must be on an edge (a vertex in no triangle is dropped)"
    lone = len(net.edges) - covered_edges(len(net), net.edges)[1].sum()
    if lone:
        return (f"{who}: links come from mesh triangles; {lone} edges lie in no triangle of the "
                "network (a degenerate triangle crashed pybullet 3.2.7)")
    return None


def covered_edges(n, edges) -> tuple[np.ndarray, np.ndarray]:
    """(every 3-clique of the edge graph (t, 3), whether each edge lies in one (m,))."""
    pairs = np.sort(edges, axis=1)
    upper = sp.csr_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    common = upper[pairs[:, 0]].multiply(upper[pairs[:, 1]]).tocoo()  # k > j, joined to i and j
    cliques = np.column_stack([pairs[common.row], common.col]).astype(int)
    covered = np.zeros(len(pairs), bool)
    if len(cliques):
        in_clique = np.concatenate([cliques[:, [0, 1]], cliques[:, [1, 2]], cliques[:, [0, 2]]])
        keys = in_clique[:, 0] * n + in_clique[:, 1]
        covered = np.isin(pairs[:, 0] * n + pairs[:, 1], keys)
    return cliques.reshape(-1, 3), covered


def triangles(n, edges) -> np.ndarray:
    """(t, 3) vertex triples whose sides are exactly `edges` (every edge in a 3-clique)."""
    cliques, covered = covered_edges(n, edges)
    if not covered.all():
        raise ValueError("network.edges: every edge must lie in a triangle for pybullet")
    return cliques


def write_obj(path, positions, tris) -> None:
    lines = [f"v {a!r} {b!r} {c!r}" for a, b, c in np.asarray(positions, float).tolist()]
    lines += [f"f {a} {b} {c}" for a, b, c in (np.asarray(tris) + 1).tolist()]
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")


def load_network(p, cid, scene) -> int:
    """The network as a soft body with its rest lengths captured and pinned nodes anchored;
    the nodes at the scene's positions, at rest. Returns the body id."""
    net = scene.parts_of(SpringNetwork)[0]
    free = np.ones(len(net), bool)
    free[net.pinned] = False
    node_mass = float(net.masses[free][0]) if free.any() else float(net.masses[0])
    with tempfile.TemporaryDirectory(prefix="refsim_pb_net_") as tmp:
        path = os.path.join(tmp, "network.obj")
        # the mesh at the rest geometry (capture-step force ~0), but never all in one point
        # (a mesh of coincident vertices segfaulted pybullet 3.2.7; the capture force is 0
        # there anyway, d = 0 giving u = 0)
        scale = rest_scale(net) or 1.0
        write_obj(path, scale * net.positions, triangles(len(net), net.edges))
        body = p.loadSoftBody(
            path, mass=node_mass * len(net), useMassSpring=1, useBendingSprings=0,
            springBendingStiffness=0.0,  # not 0.1: the server ignores useBendingSprings
            springElasticStiffness=float(net.stiffness[0]),
            springDampingStiffness=float(net.damping[0]), springDampingAllDirections=0,
            useNeoHookean=0, useSelfCollision=0, useFaceContact=0, frictionCoeff=0.0,
            physicsClientId=cid)
    count = p.getMeshData(body, -1, flags=p.MESH_DATA_SIMULATION_MESH, physicsClientId=cid)[0]
    if count != len(net):
        raise RuntimeError(f"pybullet made {count} soft-body nodes of {len(net)} network nodes")
    for node in net.pinned.tolist():
        p.createSoftBodyAnchor(body, node, -1, -1, physicsClientId=cid)
    capture_rest_lengths(p, cid, body, rest_scale(net) * net.positions, scene)  # float64
    p.resetMeshData(body, net.positions.tolist(), physicsClientId=cid)
    return body


def capture_rest_lengths(p, cid, body, rest_positions, scene) -> None:
    """One CAPTURE_DT step with the nodes at the rest geometry and gravity off: pybullet resets
    its rest lengths from the positions there (elastic forces ~0, so v stays ~0)."""
    p.resetMeshData(body, np.asarray(rest_positions, float).tolist(), physicsClientId=cid)
    p.setGravity(0.0, 0.0, 0.0, physicsClientId=cid)
    p.setPhysicsEngineParameter(fixedTimeStep=CAPTURE_DT, numSubSteps=0, physicsClientId=cid)
    p.stepSimulation(physicsClientId=cid)
    p.setGravity(*scene.gravity, physicsClientId=cid)


def node_positions(p, cid, body) -> np.ndarray:
    return np.array(p.getMeshData(body, -1, flags=p.MESH_DATA_SIMULATION_MESH,
                                  physicsClientId=cid)[1], float)


def step_nodes(p, cid, body, n, x, dt):
    """n pybullet steps of a soft body whose node positions are x before them: (positions
    after, velocities (x_n - x_(n-1)) / dt from the last step: the API gives no node
    velocities)."""
    step = p.stepSimulation
    for _ in range(n - 1):
        step(physicsClientId=cid)
    previous = node_positions(p, cid, body) if n > 1 else x
    step(physicsClientId=cid)
    after = node_positions(p, cid, body)
    return after, (after - previous) / dt
