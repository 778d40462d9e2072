"""pybullet's finite-element group: one `TetMesh` of the stable Neo-Hookean law as pybullet's own
deformable body (what pybullet computes and the facts measured: adapters/pybullet_engine/
fem_softbody.py; the .vtk and the orientation check: fem_vtk.py).

Two ways to run it, chosen by the scene as in refsim's own fem group:
- static (scene.meta["solve"] == "static"): "steady", the equilibrium by damped dynamics in
  pybullet's own step, in stages of growing step and damping (adapters/pybullet_engine/
  fem_relax.py: why stages, the stop rule, what it reaches). One `step()` is one complete solve
  from the mesh's initial positions, at rest.
- dynamic (any other scene): pybullet's deformable step, undamped (NeoHookeanDamping 0): kick
  v += h (gravity + elastic force at x_n) / m, drift x += h v: refsim's `symplectic_euler`.

Refused, with the reason: a TriangleMesh (pybullet has no plane-stress/strain element), any
law but neo_hookean, plasticity, nodal loads (no force reaches a soft-body node), initial
velocities (cannot be set), contacts, a static scene without pinned nodes.
Observes x (getMeshData, float64) and v of every node: 0 for "steady", (x_n - x_{n-1}) / h
when stepped; "steady" also `iterations` (pybullet steps of the last solve), `stages` and
`error_floor` (m: the static error floor of the stage kept, fem_relax.py).
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup, Sim
from refsim.integrators.spec import spec_name
from refsim.scene import TriangleMesh, single_mesh

from .. import fem_relax as relax
from ..fem_relax import Relaxation
from ..fem_softbody import TetFile, load_mesh, softbody_settings
from ..runtime import INTEGRATOR, OwnsClient, c_stdout_silenced, import_pybullet
from ..softbody import node_positions, step_nodes

STEADY = {"name": "steady", "order": 0, "family": "static solve (damped dynamics)",
          "explicit": False, "symplectic": False}
INTEGRATORS = ("steady", "symplectic_euler")


def _mesh(scene):
    return single_mesh(scene)


def claims(scene) -> bool:
    return _mesh(scene) is not None


def _mesh_reason(mesh) -> str | None:
    who = "pybullet fem"
    if isinstance(mesh, TriangleMesh):
        return (f"{who}: no plane-stress or plane-strain element (its deformable world's "
                "elastic solids are tetrahedral .vtk meshes; triangle soft bodies are "
                "mass-spring cloth)")
    if mesh.material.strain != "neo_hookean":
        return (f"{who}: loadSoftBody offers one elastic law for tetrahedra, the stable "
                f"Neo-Hookean (Smith et al. 2018), got strain {mesh.material.strain!r}")
    if mesh.material.plasticity is not None:
        return f"{who}: no plasticity in pybullet's deformable world"
    if np.any(mesh.loads != 0):
        return (f"{who}: no nodal loads (applyExternalForce on a soft-body node is not read by "
                "the deformable world's solver)")
    if np.any(mesh.velocities != 0):
        return f"{who}: node velocities cannot be set (resetMeshData writes positions only)"
    return None


def supports(engine, scene, integrator):
    if scene.part_kinds() != {"meshes"}:
        return (f"pybullet fem: one mesh alone, got also "
                f"{', '.join(sorted(scene.part_kinds() - {'meshes'}))}")
    if scene.contact is not None:
        return "pybullet fem: no contact (the mesh is alone)"
    mesh = _mesh(scene)
    reason = _mesh_reason(mesh)
    if reason:
        return reason
    static = scene.meta.get("solve") == "static"
    name = spec_name(integrator)
    if static and not len(mesh.pinned):
        return ("pybullet fem: a static scene needs pinned nodes (only anchors and gravity act "
                "on a pybullet soft body)")
    if name and static and name != "steady":
        return ("pybullet fem: the scene asks for its static equilibrium (meta solve = "
                "static), reached by 'steady' (damped dynamics), not stepped by " + name)
    if name and not static and name != "symplectic_euler":
        return ("pybullet fem: its deformable world has one stepper (explicit elastic forces "
                f"and gravity, then drift), offered as symplectic_euler, not {name}")
    return None


class _Client(OwnsClient):
    def _connect(self, p):
        self.p = p
        with c_stdout_silenced():
            self.client = p.connect(p.DIRECT)

    def close(self):
        super().close()
        tet_file = getattr(self, "tet_file", None)
        if tet_file is not None:
            tet_file.cleanup()
            self.tet_file = None


class StaticSim(_Client, Sim):
    """The mesh's equilibrium under gravity and its pinned nodes, by staged damped dynamics."""

    def __init__(self, p, scene, dt):
        self.dt, self.scene, self.mesh = float(dt), scene, _mesh(scene)
        self._connect(p)
        try:
            self.tet_file = TetFile(self.mesh)
            self.relaxation = Relaxation(p, self.client, self.mesh, self.tet_file,
                                         scene.gravity)
        except Exception:
            self.close()
            raise
        self.x = np.array(self.mesh.positions, float)
        self.iterations, self.stage_log, self.floor = 0, [], float("nan")

    def _step_impl(self, n):
        for _ in range(n):  # every step the same complete solve from the initial positions
            self.x, self.iterations, self.stage_log, self.floor = \
                self.relaxation.solve(self.mesh.positions)

    def _observe(self):
        return {"x": self.x.copy(), "v": np.zeros_like(self.x), "iterations": self.iterations,
                "stages": len(self.stage_log), "error_floor": self.floor}

    def settings(self):
        return {
            "integrator": dict(STEADY), **softbody_settings(self.mesh),
            "solver": relax.DESCRIPTION,
            "w_min_rad_per_s": self.relaxation.w_min,
            "w_min_and_a_from": "refsim's model of the same law (rest stiffness, forces) with "
                                "pybullet's masses: they choose h; the positions are pybullet's",
            "floor": "a stage settles to a static error of about 1e-8 m/s / (h w_min^2) (its "
                     "floor_m): the damping solve skips velocity changes under 1e-8 m/s",
            "step": "one complete static solve from the initial positions",
        }


class DynamicSim(_Client, Sim):
    def __init__(self, p, scene, dt):
        self.dt, self.scene, self.mesh = float(dt), scene, _mesh(scene)
        self._connect(p)
        try:
            self.tet_file = TetFile(self.mesh)
            self.body = load_mesh(p, self.client, self.mesh, self.tet_file, 0.0, scene.gravity)
            p.setPhysicsEngineParameter(fixedTimeStep=self.dt, numSubSteps=0,
                                        physicsClientId=self.client)
            self.engine_params = p.getPhysicsEngineParameters(physicsClientId=self.client)
        except Exception:
            self.close()
            raise
        self.x = node_positions(p, self.client, self.body)
        self.v = np.zeros_like(self.x)

    def _step_impl(self, n):
        self.x, self.v = step_nodes(self.p, self.client, self.body, n, self.x, self.dt)

    def _observe(self):
        return {"x": self.x.copy(), "v": self.v.copy()}

    def settings(self):
        prm = self.engine_params
        return {
            "integrator": dict(INTEGRATOR, native=(
                "btDeformableBodySolver, setImplicit(false), no damping: v += h (gravity + "
                "Neo-Hookean force at x_n) / m; x += h v")),
            **softbody_settings(self.mesh), "NeoHookeanDamping_s": 0.0,
            "damping_solve": "none: with NeoHookeanDamping 0 its right-hand side is 0 and the "
                             "conjugate-residual solve returns at once",
            "fixedTimeStep": prm["fixedTimeStep"], "numSubSteps": prm["numSubSteps"],
            "gravity": [prm[f"gravityAcceleration{c}"] for c in "XYZ"],
            "observed_v": "(x_n - x_{n-1}) / h: pybullet 3.2.7's Python API gives no node "
                          "velocities; round-off |x| eps / h",
            "python_calls_per_step": 1,
        }


def build(engine, scene, dt, integrator, formulation):
    p = import_pybullet()
    if spec_name(integrator) == "steady":
        return StaticSim(p, scene, dt)
    return DynamicSim(p, scene, dt)


MODEL_GROUP = ModelGroup(name="fem", build=build, claims=claims,
                         parts=frozenset({"meshes"}),
                         features=frozenset({"fem", "gravity", "plasticity"}),
                         supports=supports, integrators=INTEGRATORS)
