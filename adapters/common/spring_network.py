"""What the engines' spring-network groups share (cloth, rope, hair: `SpringNetwork` parts,
refsim.models.spring_network): which scenes they claim, the steppers offered, the reasons a
scene is refused, and the observation every engine returns.

Every engine offers the same four steppers on a network (issue 16): symplectic Euler, velocity
Verlet, RK4 and Baraff & Witkin's linearised implicit step; an engine whose own integrator is
fixed maps them in its group and says so in `settings`.
"""
from __future__ import annotations

import numpy as np

from refsim.scene import SpringNetwork

NETWORK_INTEGRATORS = ("symplectic_euler", "velocity_verlet", "rk4", "baraff_witkin")


def claims(scene) -> bool:
    return bool(scene.parts_of(SpringNetwork))


def scene_reason(scene, who: str) -> str | None:
    """Reasons a network scene is refused whatever the stepper: one network, nothing else."""
    if len(scene.parts_of(SpringNetwork)) != 1:
        return f"{who} spring networks: one network per scene, got {len(scene.parts_of(SpringNetwork))}"
    others = scene.part_kinds() - {"networks"}
    if others:
        return f"{who} spring networks: a network alone, got also {', '.join(sorted(others))}"
    return None


def integrator_reason(integrator: str | None, offered=NETWORK_INTEGRATORS) -> str | None:
    if integrator is None or integrator in offered:
        return None
    return f"spring networks: integrator must be one of {list(offered)}, got {integrator!r}"


def solve_formulations(scene) -> tuple:
    """The formulations of Baraff-Witkin's linear solve an engine offers on this scene: ""
    (direct) and "cg" where the in-house step solves sparsely (3 n_free >= SPARSE_MIN, so the
    engines' rows pair up), else "" alone (a dense solve: CG would change nothing)."""
    from refsim.integrators.implicit import SPARSE_MIN
    net = scene.part(SpringNetwork)
    return ("", "cg") if 3 * (len(net) - len(net.pinned)) >= SPARSE_MIN else ("",)


def free_mask(net) -> np.ndarray:
    """(n,) bool: the nodes that move (not pinned)."""
    free = np.ones(len(net), bool)
    free[net.pinned] = False
    return free


def observation(x_nodes, v_nodes) -> dict:
    """The observed "x", "v": every node (pinned ones included), (n, 3) float arrays."""
    return {"x": np.array(x_nodes, float).reshape(-1, 3),
            "v": np.array(v_nodes, float).reshape(-1, 3)}
