"""pybullet's spring-network group: a `SpringNetwork` (cloth, membrane, rope) as pybullet's own
mass-spring soft body in the deformable world (formulation "softbody"; what pybullet does and
the measured facts: adapters/pybullet_engine/softbody.py).

Stepper: pybullet's one deformable step, offered as `symplectic_euler` (what it is without
damping: kick v += h a(x_n), drift x += h v); edge damping, when present, is solved implicitly
(IMEX), and settings say so. The other network steppers are refused with that reason.
Refused networks (softbody.softbody_reason): hinges/dihedrals, air drag, initial velocities,
per-edge stiffness/damping or per-node masses that differ, edges in no
triangle, rest lengths that are not a scaled
copy of the initial lengths.
Observes x of every node (getMeshData, float64) and v = (x_n - x_{n-1}) / h.
"""
from __future__ import annotations

import numpy as np

from refsim_adapters.common.spring_network import claims, observation, scene_reason
from refsim.engine import ModelGroup, Sim
from refsim.scene import SpringNetwork

from ..runtime import INTEGRATOR, OwnsClient, c_stdout_silenced, import_pybullet
from ..softbody import (
    CAPTURE_DT,
    CR_MAX_ITERATIONS,
    CR_TOLERANCE,
    MAX_DISPLACEMENT,
    SLEEP_SPEED,
    SLEEP_TIME,
    load_network,
    node_positions,
    rest_scale,
    softbody_reason,
    step_nodes,
)

FORMULATIONS = {"softbody": "pybullet's mass-spring soft body (loadSoftBody useMassSpring=1, "
                            "deformable world)"}
STEPPER_REASON = ("pybullet's deformable world has one stepper (explicit elastic forces and "
                  "gravity, implicit damping, then drift): offered as symplectic_euler")


class PybulletNetworkSim(OwnsClient, Sim):
    def __init__(self, p, scene, dt):
        self.p, self.scene, self.dt, self.steps = p, scene, dt, 0
        self.net = scene.parts_of(SpringNetwork)[0]
        with c_stdout_silenced():
            self.client = p.connect(p.DIRECT)
        try:
            p.resetSimulation(p.RESET_USE_DEFORMABLE_WORLD, physicsClientId=self.client)
            p.setGravity(*scene.gravity, physicsClientId=self.client)  # before the body: its
            self.body = load_network(p, self.client, scene)  # gravity force is made at load
            p.setPhysicsEngineParameter(fixedTimeStep=dt, numSubSteps=0,
                                        physicsClientId=self.client)
            self.engine_params = p.getPhysicsEngineParameters(physicsClientId=self.client)
            self.x = node_positions(p, self.client, self.body)
            self.v = np.zeros_like(self.x)
        except Exception:
            self.close()
            raise

    def _step_impl(self, n):
        self.x, self.v = step_nodes(self.p, self.client, self.body, n, self.x, self.dt)

    def _observe(self):
        return observation(self.x, self.v)

    def settings(self):
        prm, net, dt = self.engine_params, self.net, self.dt
        damped = bool(net.damping[0] > 0)
        x = net.positions
        diagonal = float(np.linalg.norm(x.max(axis=0) - x.min(axis=0)))
        return {
            "integrator": dict(INTEGRATOR, native=(
                "btDeformableBodySolver, setImplicit(false): v* = v + h (gravity + elastic)/m; "
                "damping solved implicitly M (v' - v*) = h f_damp(v'); x' = x + h v'"),
                damping_implicit=damped),
            "formulation": FORMULATIONS["softbody"], "dtype": "float64", "threads": 1,
            "connection": "DIRECT", "world": "RESET_USE_DEFORMABLE_WORLD",
            "fixedTimeStep": prm["fixedTimeStep"], "numSubSteps": prm["numSubSteps"],
            "gravity": [prm[f"gravityAcceleration{c}"] for c in "XYZ"],
            "springElasticStiffness_N_per_m": float(net.stiffness[0]),
            "stiffness_mapping": "per link, N/m, not scaled by rest length: k (d - r d/|d|)",
            "springDampingStiffness_Ns_per_m": float(net.damping[0]),
            "damping_direction": "along the link (springDampingAllDirections=0)",
            "damping_solve": (f"conjugate residual, absolute tolerance {CR_TOLERANCE:g}, at "
                              f"most {CR_MAX_ITERATIONS} iterations" if damped else "none"),
            "bending_springs": "off (useBendingSprings=0)", "self_collision": "off",
            "node_mass_kg": "total mass / n on every node (setTotalMass); pinned nodes mass 0",
            "pinned": "createSoftBodyAnchor to the world (node mass 0: exact)",
            "rest_lengths": (f"captured: {rest_scale(net):g} x initial lengths, by one "
                             f"{CAPTURE_DT:g} s step at that geometry with gravity off"),
            "mesh": ".obj of the network's 3-cliques (every edge in one), vertices in node "
                    "order, written to a temporary directory",
            "velocity_clamp_norm_m_per_s": diagonal / dt,
            "velocity_clamp_norm_note": ("|v| <= bounding-box diagonal / h per node before the "
                                         "drift (initial diagonal shown; pybullet uses the "
                                         "current one plus the collision margin)"),
            "velocity_clamp_component_m_per_s": MAX_DISPLACEMENT / dt,
            "sleeping": f"frozen after {SLEEP_TIME:g} s with every node below "
                        f"{SLEEP_SPEED:g} m/s (btSoftBody defaults)",
            "position_correction": "none (no contacts; world anchors are mass-0 nodes)",
            "observed_v": "(x_n - x_{n-1}) / h: pybullet 3.2.7's Python API gives no node "
                          "velocities; round-off |x| eps / h",
            "python_calls_per_step": 1,
        }


def supports(engine, scene, integrator):
    reason = scene_reason(scene, "pybullet")
    if reason:
        return reason
    if integrator is not None and integrator != "symplectic_euler":
        return f"{STEPPER_REASON}, got {integrator!r}"
    return softbody_reason(scene)


def build(engine, scene, dt, integrator, formulation):
    return PybulletNetworkSim(import_pybullet(), scene, dt)


MODEL_GROUP = ModelGroup(name="spring_network", build=build, claims=claims,
                         parts=frozenset({"networks"}),
                         features=frozenset({"networks", "gravity", "drag"}),
                         supports=supports,
                         formulations=lambda engine, scene: tuple(FORMULATIONS),
                         integrators=("symplectic_euler",))
