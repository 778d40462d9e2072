"""The in-house engine's n-body gravity: the scene's particles attract in all pairs
(`GravityPairs`, Newton's law with Plummer softening eps), `refsim.models.nbody_gravity`
(`GravitySystem`: accelerations of every pair, vectorised, no cut-off), stepped by the fixed-step
`refsim.integrators` steppers on the flat state (3n,). A uniform `scene.gravity` field, when
set, is added to every acceleration.

Integrators: symplectic Euler (kick-drift) and velocity Verlet (symplectic: the force is
conservative and velocity-free, so (x, m v) are canonical and the maps are symplectic), explicit Euler, explicit midpoint,
RK4, Dormand-Prince adaptive, and implicit Euler with the analytic Jacobian da/dx
(`pair_jacobian`, dense 3n x 3n: offered up to MAX_IMPLICIT_BODIES bodies).

Observes x, v (n, 3) and the extras `energy` () J (1/2 sum m |v|^2 + U - sum m g . x),
`momentum` (3,) kg m/s, `angular_momentum` (3,) kg m^2/s about the origin, and, for two
bodies, `runge_lenz` (3,) the eccentricity vector of the relative orbit (dimensionless).
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup
from refsim.integrators import get_integrator
from refsim.integrators.spec import spec_name
from refsim.models.nbody_gravity import GravitySystem
from refsim.scene.gravity_pairs import GravityPairs
from refsim.scene import Particles

from ..stepped import SteppedSim

# implicit_midpoint (symplectic, no Jacobian needed) is not offered: its fixed-point
# sweeps cost 10x a Verlet step and the default run's budget has no room for it
INTEGRATORS = ("symplectic_euler", "velocity_verlet", "explicit_euler", "midpoint", "rk4",
               "dopri5_adaptive", "implicit_euler")
MAX_IMPLICIT_BODIES = 100  # implicit Euler solves a dense 3n x 3n system per Newton step
BLOCK_ROWS_ABOVE = 2000  # evaluate rows in blocks of this many beyond it (bounds n^2 memory)


class GravitySim(SteppedSim):
    def __init__(self, scene, dt, stepper):
        bodies, pairs = scene.part(Particles), scene.part(GravityPairs)
        n = len(bodies)
        self.scene, self.pairs = scene, pairs
        self.block_rows = BLOCK_ROWS_ABOVE if n > BLOCK_ROWS_ABOVE else None
        system = GravitySystem(bodies.mass, pairs.G, pairs.softening, scene.gravity,
                               self.block_rows)
        super().__init__(dt, stepper, system, np.array(bodies.position, float).reshape(-1),
                         np.array(bodies.velocity, float).reshape(-1))

    def stages(self):
        field = ["gravity"] if np.any(self.scene.gravity) else []
        return ["gravity_pairs_all_pairs"] + field + [f"integrate:{self.stepper.name}"]

    def _observe(self):
        x, v = self.coordinates()
        invariants = self.system.invariants(x, v)
        out = {"x": x.reshape(-1, 3).copy(), "v": v.reshape(-1, 3).copy(),
               "energy": float(invariants.pop("energy"))}
        return {**out, **invariants}

    def settings(self):
        entry = dict(self.stepper.describe())
        if entry.get("symplectic"):
            entry["symplectic_note"] = ("symplectic: conservative, velocity-independent pair "
                                        "forces, (x, m v) canonical")
        return {**self.base_settings(), "integrator": entry,
                "model": "all-pairs Newtonian gravity, Plummer softening "
                         "a_i = sum_j G m_j d / (|d|^2 + eps^2)^1.5",
                "G": self.pairs.G, "softening": self.pairs.softening,
                "pairs": "all pairs (no cut-off, no tree or mesh approximation)",
                "block_rows": self.block_rows, "uniform_field": np.asarray(self.scene.gravity, float).tolist(),
                "jacobian": "analytic da/dx (dense), da/dv = 0 (implicit steppers only)",
                "damping": "none", "velocity_clamp": None}


def _claims(scene) -> bool:
    """Scenes whose parts are exactly particles and a GravityPairs part."""
    return scene.part_kinds() == {"particles", "gravity_pairs"} and scene.contact is None


def _supports(engine, scene, integrator):
    n = len(scene.part(Particles))
    if integrator is not None and spec_name(integrator) == "implicit_euler" \
            and n > MAX_IMPLICIT_BODIES:
        return (f"refsim gravity: implicit_euler solves a dense {3 * n} x {3 * n} Jacobian "
                f"per Newton step, offered up to {MAX_IMPLICIT_BODIES} bodies (got {n})")
    return None


def _build(engine, scene, dt, integrator, formulation):
    return GravitySim(scene, dt, get_integrator(integrator))


MODEL_GROUP = ModelGroup(name="gravity_pairs", build=_build, claims=_claims,
                         parts=frozenset({"particles", "gravity_pairs"}),
                         features=frozenset({"gravity_pairs", "gravity"}),
                         supports=_supports, integrators=INTEGRATORS)
