"""pymunk's spring-network group: ropes, chains, strings, hair and in-plane cloth as one
`SpringNetwork` whose motion stays in the x-z plane (pymunk is 2D: refsim (x, z) -> pymunk
(x, y), observed y = 0).

Formulations (named in settings "formulation"):
- "" (springs; networks without hinges): point-mass bodies and `DampedSpring`s, drag as a
  force (adapters/pymunk_engine/network_springs.py);
- "space_damping" (the same, offered with drag on one node mass): drag as pymunk's global
  velocity damping exp(-c_air / m) per second;
- "rigid_links" (hair: a chain with hinges): rigid link bodies, `PivotJoint`s at the nodes,
  `DampedRotarySpring`s for the hinges; links inextensible
  (adapters/pymunk_engine/network_links.py).
Integrator: pymunk's own step only, `symplectic_euler_dk` (cpSpaceStep: drift x += h v, then the
kick v += h a(x_{k+1})); the other network steppers are refused with that reason.
Refused: scenes off the x-z plane (membranes, cloth moving in 3D), dihedral bending, and
hinges on anything but a chain pinned at its root (the reason says which).
"""
from __future__ import annotations

from refsim_adapters.common.spring_network import (
    NETWORK_INTEGRATORS,
    claims,
    integrator_reason,
    scene_reason,
)
from refsim.engine import ModelGroup
from refsim.scene import SpringNetwork

from ..network_links import RIGID_LINKS, links_reason
from ..network_springs import SPACE_DAMPING, uniform_mass

NATIVE = "symplectic_euler_dk"
INTEGRATORS = (NATIVE, *NETWORK_INTEGRATORS)
WHO = "pymunk"


def _plane_reason(scene) -> str | None:
    if scene.dim != 3 or not scene.stays_in_xz_plane():
        return ("pymunk is 2D: a spring network must keep every node, velocity and the "
                "gravity in the x-z plane (y = 0); this one moves out of it (a membrane or a "
                "cloth displaced along y)")
    return None


def supports(engine, scene, integrator):
    reason = scene_reason(scene, WHO) or integrator_reason(integrator, INTEGRATORS)
    if reason:
        return reason
    if integrator is not None and integrator != NATIVE:
        return (f"pymunk steps with its own semi-implicit Euler only (cpSpaceStep: x += h v, "
                f"then v += h a(x_new), refsim's {NATIVE}); {integrator!r} is not available "
                f"in pymunk")
    reason = _plane_reason(scene)
    if reason:
        return reason
    net = scene.parts_of(SpringNetwork)[0]
    if len(net.dihedrals):
        return ("pymunk is 2D: dihedral bending (out-of-plane folding of triangles) has no "
                "counterpart in a plane; pymunk runs networks without dihedrals")
    return links_reason(net) if len(net.hinges) else None


def formulations(engine, scene):
    net = scene.parts_of(SpringNetwork)[0]
    if len(net.hinges):
        return (RIGID_LINKS,)
    if scene.linear_drag > 0 and uniform_mass(net):
        return ("", SPACE_DAMPING)
    return ("",)


def build(engine, scene, dt, integrator, formulation):
    import pymunk  # lazily: refsim works without pymunk installed
    net = scene.parts_of(SpringNetwork)[0]
    if formulation == RIGID_LINKS:
        from ..network_links import PymunkLinkChainSim
        return PymunkLinkChainSim(pymunk, scene, dt, net)
    from ..network_springs import PymunkSpringNetworkSim
    return PymunkSpringNetworkSim(pymunk, scene, dt, net, formulation)


MODEL_GROUP = ModelGroup(name="spring_network", build=build, claims=claims,
                         parts=frozenset({"networks"}),
                         features=frozenset({"networks", "gravity", "drag"}),
                         supports=supports, formulations=formulations, integrators=INTEGRATORS)
