"""MuJoCo's finite-element group (slides 001 and 000; mujoco 4.0.0): one P1 mesh part as a
MuJoCo 4 flex (adapters/mujoco_engine/fem_mjcf.py): `TriangleMesh` as flexcomp dim="2"
dof="2d" (plane stress, `thickness`, elastic2d="stretch"), `TetMesh` as dim="3"; pinned nodes
`<pin id>`; loads through d.xfrc_applied; lumped masses rho V / (d + 1) set on the vertex
bodies (flexcomp's own split is equal per vertex: settings `mass_split`).

The law: MuJoCo's flex implements St Venant-Kirchhoff on linear elements only (Green strain
E = 1/2 (F^T F - I), energy mu tr(E^2) + lambda/2 tr(E)^2): refsim's "green". The other strain
measures (linear, corotated, neo_hookean) are refused with that reason; so are Poisson ratios
outside MuJoCo's [0, 0.5) and triangle meshes outside a z = const plane (dof="2d" moves in x
and y). Plasticity on tetrahedra runs as the flex's `yield` (ideal von Mises on the Green
strain, eps_y = sigma_y / (3 mu); what differs from refsim's rule: adapters/mujoco_engine/
fem_yield.py and settings `plasticity`); hardening, triangles and static scenes with
plasticity are refused (fem_yield.yield_reason). Plane strain runs on the plane-stress
flex with E' = E / (1 - nu^2), nu' = nu / (1 - nu): the same in-plane StVK law (nu < 1/3).

Two ways to run it, chosen by the scene as in the in-house group:
- a static scene (meta solve = "static"): MuJoCo has no static solve, so "steady" is damped
  dynamics to equilibrium (adapters/mujoco_engine/fem_settle.py: Euler, mass-proportional
  damping, the timestep and the stop rule in settings `settle`); one step is one complete
  settle from the initial positions; observes `residual` (MuJoCo's elastic + external forces
  on the free dofs at the end, N) and `iterations` (MuJoCo steps taken). The case's bound is
  its static solve's: a settle stopped early is judged by it;
- any other scene: MuJoCo's integrators at the scene's dt, no damping: "symplectic_euler"
  (Euler, eulerdamp disabled: kick then drift, every force explicit), "rk4" (RK4) and
  "discrete" (MuJoCo's linearised backward Euler). "implicit" and "implicitfast" are refused:
  MuJoCo 4 raises an error for flex elasticity under them.
Observes x, v (n, 3) of every node (pinned ones included).
"""
from __future__ import annotations

from refsim.engine import ModelGroup
from refsim.integrators.spec import spec_name

WHO = "mujoco fem"
STEPPERS = ("symplectic_euler", "rk4", "discrete")
INTEGRATORS = ("steady",) + STEPPERS + ("implicit", "implicitfast")
LAW_REASON = (f"{WHO}: MuJoCo flex implements St Venant-Kirchhoff only (Green strain on P1 "
              "elements: refsim's 'green'), not {strain}")
REFUSED = {
    "implicit": f"{WHO}: MuJoCo 4 raises an error for flex elasticity under integrator "
                "'implicit' ('flex elasticity is no longer integrated implicitly under "
                "implicit and implicitfast'): use discrete, or Euler with a small timestep",
    "implicitfast": f"{WHO}: MuJoCo 4 raises an error for flex elasticity under integrator "
                    "'implicitfast' (as for 'implicit'): use discrete, or Euler with a small "
                    "timestep",
}
TREATED_IMPLICITLY = {
    "symplectic_euler": "nothing (kick then drift; eulerdamp disabled)",
    "rk4": "nothing (explicit)",
    "discrete": "the flex's elastic stiffness and damping (MuJoCo's linearised backward "
                "Euler, its own linear solve); gravity and loads explicit",
    "steady": "nothing (Euler, kick then drift; the damping tendons explicit)",
}


NOTES = {
    "symplectic_euler": "semi-implicit Euler, kick then drift (v += h a(x, v); q += h v), "
                        "eulerdamp disabled: refsim's symplectic_euler on the same lumped "
                        "masses and StVK forces (measured equal to round-off)",
    "rk4": "classical 4-stage Runge-Kutta on (q, v): refsim's rk4 (measured equal to "
           "round-off)",
    "discrete": "MuJoCo's linearised backward Euler with the flex's stiffness: first order, "
                "damping; not refsim's implicit_euler or baraff_witkin (measured 12 % further "
                "from a converged vibrating strip than backward Euler at dt = 1 ms)",
    "steady": "damped dynamics to equilibrium by MuJoCo's Euler (settings 'settle')",
}


def _method(integrator):
    from dataclasses import replace
    from ..methods import METHODS
    native = "symplectic_euler" if integrator == "steady" else integrator
    return replace(METHODS[native], note=NOTES[integrator])


def _mesh(scene):
    from ..fem_mjcf import mesh_of
    return mesh_of(scene)


def claims(scene) -> bool:
    return _mesh(scene) is not None


def _mesh_reason(mesh, static) -> str | None:
    from ..fem_mjcf import constants_reason, plane_reason
    from ..fem_yield import yield_reason
    if mesh.material.strain != "green":
        return LAW_REASON.format(strain=repr(mesh.material.strain))
    reason = yield_reason(mesh, static)
    if reason:
        return reason
    if len(mesh.pinned) == len(mesh):
        return f"{WHO}: every node pinned, nothing to simulate"
    return plane_reason(mesh) or constants_reason(mesh)


def supports(engine, scene, integrator):
    if scene.part_kinds() != {"meshes"}:
        return (f"{WHO}: one mesh alone, got also "
                f"{', '.join(sorted(scene.part_kinds() - {'meshes'}))}")
    static = scene.meta.get("solve") == "static"
    reason = _mesh_reason(_mesh(scene), static)
    if reason:
        return reason
    name = spec_name(integrator)
    if name in REFUSED:
        return REFUSED[name]
    if name and static and name != "steady":
        return (f"{WHO}: the scene asks for its static equilibrium (meta solve = static), "
                "reached by 'steady' (damped dynamics), not stepped by " + name)
    if name and not static and name not in STEPPERS:
        return f"{WHO} steps a dynamic scene with {', '.join(STEPPERS)}, not {name}"
    if scene.contact is not None:
        return f"{WHO}: no contact (the mesh is alone)"
    return None


def build(engine, scene, dt, integrator, formulation):
    from ..fem_sim import MujocoFemSettle, MujocoFemSim
    kind = MujocoFemSettle if integrator == "steady" else MujocoFemSim
    return kind(scene, dt, integrator, _method(integrator), TREATED_IMPLICITLY[integrator])


MODEL_GROUP = ModelGroup(name="fem", build=build, claims=claims,
                         parts=frozenset({"meshes"}),
                         features=frozenset({"fem", "gravity", "plasticity"}),
                         supports=supports, integrators=INTEGRATORS)
