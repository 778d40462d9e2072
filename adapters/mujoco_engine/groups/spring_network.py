"""MuJoCo's spring-network group (cloth, rope, hair as one `SpringNetwork`; mujoco 4.0.0).

Formulation "" ("tendon"): free nodes are 3-slide bodies, pinned nodes world
sites, stretch edges spatial tendons with stiffness k, springlength L0 and damping c, air drag
joint damping (adapters/mujoco_engine/network_mjcf.py): exactly the in-house stretch model.
Hinges and dihedrals cannot be tendons: formulation "" refuses them (BENDING_REASON).

Formulation "flex" (the only one offered for a network with hinges): a hair as a 1-D flexcomp
discrete elastic rod for bending plus the same tendons for stretching
(adapters/mujoco_engine/network_flex.py: the mapping E I = k_b (l0 + l1) / 2 and its
tan(phi/2) bending measure); chains that one rod cannot hold are refused with the reason.

Not offered, with the reasons (mujoco 4.0.0, its changelog and measured):
- "cable" (composite type="cable" + the mujoco.elasticity.cable plugin): both were removed in
  mujoco 4.0.0 (changelog, Deformables, breaking change 9: superseded by 1D flexcomp with
  elasticity); the wheel ships no libelasticity plugin;
- flex EDGE stiffness/damping for ropes and cloths (flexcomp dim=1/2): one stiffness, damping
  and rest configuration (qpos0) per flex, so it represents a network only with uniform k, c
  and L0 = initial lengths, and edge stiffness is refused under `discrete` (changelog 13); the
  tendons already are the exact stretch model, so "flex" uses them for stretching too.

Integrators (measured in tests/engines/mujoco/test_mujoco_spring_network.py):
- symplectic_euler -> Euler with eulerdamp disabled: the in-house step to round-off;
- rk4 -> RK4: the in-house RK4 to round-off;
- discrete (MuJoCo's own name, offered besides): (M + h D + h^2 K) a = f - h K v, v += h a,
  q += h v with D = sum c u u^T + c_air I and K = sum k u u^T only, the tendon's stiffness along
  itself: the geometric stiffness (f / L)(I - u u^T) of each edge is left out. Baraff-Witkin
  keeps it, so discrete is NOT refsim's baraff_witkin (they differ by 6.7e-2 m/s in 20 steps
  on a zero-rest-length string); measured equal to a replica of that partial-K step to 5e-16.
  A tendon whose length equals its springlength EXACTLY adds no stiffness to K (the closed
  deadband [L0, L0] of MuJoCo's two-value springlength): a cloth built at its rest lengths
  takes its first discrete step without K (measured);
- velocity_verlet and baraff_witkin are refused with those reasons.
"""
from __future__ import annotations

from dataclasses import replace

from refsim_adapters.common.spring_network import NETWORK_INTEGRATORS, claims, scene_reason
from refsim.engine import ModelGroup
from refsim.scene import SpringNetwork

WHO = "mujoco adapter"
OWN_INTEGRATORS = ("discrete",)
OFFERED = NETWORK_INTEGRATORS + OWN_INTEGRATORS
RUNS = ("symplectic_euler", "rk4", "discrete")
BENDING_REASON = (
    f"{WHO} spring networks: hinges and dihedrals cannot be tendons (formulation \"tendon\" "
    "has stretch springs only), and the cable plugin and composite element that modelled bending "
    "were removed in mujoco 4.0.0")
REFUSED = {
    "velocity_verlet": f"{WHO}: MuJoCo has no velocity Verlet integrator (Euler, RK4, "
                       "implicit, implicitfast, discrete)",
    "baraff_witkin": f"{WHO}: MuJoCo's closest step, discrete, linearises backward Euler with "
                     "only the tendon stiffness k u u^T along each edge (no geometric "
                     "stiffness (f/L)(I - u u^T)), so it is not Baraff-Witkin: run it as "
                     "'discrete'",
}
TREATED_IMPLICITLY = {
    "symplectic_euler": "nothing (kick then drift; eulerdamp disabled, so tendon and joint "
                        "damping are explicit too)",
    "rk4": "nothing (explicit)",
    "discrete": "tendon damping c u u^T, joint damping c_air I and tendon stiffness k u u^T "
                "(h D + h^2 K added to M); gravity and the geometric stiffness (f/L)(I - u u^T) "
                "of each edge stay explicit; a tendon exactly at its rest length adds no "
                "stiffness (springlength deadband [L0, L0] closed: measured)",
}
_NOTES = {
    "symplectic_euler": "semi-implicit Euler, kick then drift (v += h a(x, v); q += h v), "
                        "eulerdamp disabled: the in-house symplectic_euler",
    "rk4": "classical 4-stage Runge-Kutta on (q, v): the in-house rk4",
    "discrete": "(M + h D + h^2 K) a = f(q, v) - h K v, v += h a, q += h v with D, K the "
                "damping and tendon-stiffness derivatives (no geometric stiffness): a "
                "linearised backward Euler that is not Baraff-Witkin; unconditionally stable "
                "along the edges, damps like backward Euler",
}


def network_methods() -> dict:
    """The engine's Method records with spring-network notes."""
    from ..methods import METHODS
    return {name: replace(METHODS[name], note=_NOTES[name]) for name in RUNS}


FLEX_TREATED_IMPLICITLY = {
    "discrete": TREATED_IMPLICITLY["discrete"] + "; the rod's bending forces by MuJoCo's "
                "positive semi-definite Hessian approximation (XML reference, flex/elasticity)",
}


def _bends(net) -> bool:
    return bool(len(net.hinges) or len(net.dihedrals))


def supports(engine, scene, integrator):
    from ..network_flex import flex_reason
    reason = scene_reason(scene, WHO)
    if reason:
        return reason
    net = scene.parts_of(SpringNetwork)[0]
    if _bends(net):
        flex = flex_reason(net)
        if flex:
            return f"{BENDING_REASON}; {flex}"
    return REFUSED.get(integrator)


def formulations(engine, scene):
    """"flex" alone for a network with hinges (the tendon formulation has no bending), ""
    alone otherwise."""
    return ("flex",) if _bends(scene.parts_of(SpringNetwork)[0]) else ("",)


def build(engine, scene, dt, integrator, formulation):
    from ..network_flex_sim import MujocoFlexSim
    from ..network_sim import MujocoNetworkSim
    if integrator not in RUNS:
        raise ValueError(REFUSED.get(integrator) or
                         f"mujoco spring-network integrator must be one of {list(RUNS)}, "
                         f"got {integrator!r}")
    if formulation == "flex":
        return MujocoFlexSim(scene, dt, integrator, network_methods()[integrator],
                             FLEX_TREATED_IMPLICITLY.get(integrator,
                                                         TREATED_IMPLICITLY[integrator]))
    return MujocoNetworkSim(scene, dt, integrator, network_methods()[integrator],
                            TREATED_IMPLICITLY[integrator])


MODEL_GROUP = ModelGroup(
    name="spring_network", build=build, claims=claims, parts=frozenset({"networks"}),
    features=frozenset({"networks", "gravity", "drag"}), supports=supports,
    formulations=formulations, integrators=OFFERED)
