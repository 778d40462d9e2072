"""The in-house engine's flocking group: particles under a `Flocking` part (Cucker-Smale or
Reynolds rules, all pairs, `refsim.models.flocking`), stepped by a fixed-step
`refsim.integrators` stepper on the flat (3n,) state. Observes the particles' x, v (n, 3).
"""
from __future__ import annotations

from refsim.engine import ModelGroup
from refsim.integrators import get_integrator
from refsim.models.flocking import FlockSystem
from refsim.scene.flocking import Flocking
from refsim.scene import Particles

from ..stepped import SteppedSim

# the explicit and symplectic fixed-step steppers: every one keeps the mean velocity (its
# increments are sums of accelerations, each with zero sum over the birds); the implicit ones
# would need N^2-sized Jacobians of a rule that is not stiff here
INTEGRATORS = ("explicit_euler", "symplectic_euler", "symplectic_euler_dk", "midpoint", "heun",
               "rk2", "rk4", "dopri5", "stormer_verlet", "velocity_verlet", "leapfrog")


class FlockSim(SteppedSim):
    def __init__(self, scene, dt, stepper):
        self.scene, self.flocking = scene, scene.part(Flocking)
        birds = scene.part(Particles)
        system = FlockSystem(self.flocking, len(birds))
        super().__init__(dt, stepper, system, birds.position.reshape(-1),
                         birds.velocity.reshape(-1))

    def stages(self):
        return self.system.stages() + [f"integrate:{self.stepper.name}"]

    def _observe(self):
        x, v = self.coordinates()
        return {"x": x.reshape(-1, 3), "v": v.reshape(-1, 3)}

    def settings(self):
        f = self.flocking
        rule = ({"K": f.K, "sigma": f.sigma, "beta": f.beta} if f.rule == "cucker_smale" else
                {"radius": f.radius, "separation": f.separation, "alignment": f.alignment,
                 "cohesion": f.cohesion})
        entry = dict(self.stepper.describe())
        if entry.get("symplectic"):
            entry.update(symplectic=False, symplectic_note="the flocking rules are "
                         "dissipative (velocity-dependent, no Hamiltonian): no symplectic "
                         "structure to keep")
        return {**self.base_settings(), "integrator": entry, "rule": f.rule, **rule,
                "pairs": "all pairs, (N, N) numpy arrays"}


def _claims(scene) -> bool:
    return scene.part(Flocking) is not None


def _supports(engine, scene, integrator):
    if integrator is not None and integrator not in INTEGRATORS:
        return (f"refsim flocking: integrator must be one of {list(INTEGRATORS)} (got "
                f"{integrator!r})")
    if scene.part(Particles) is None:
        return "refsim flocking needs the birds as a Particles part"
    return None


def _build(engine, scene, dt, integrator, formulation):
    return FlockSim(scene, dt, get_integrator(integrator))


MODEL_GROUP = ModelGroup(name="flocking", build=_build, claims=_claims,
                         parts=frozenset({"particles", "flocking"}),
                         features=frozenset({"flocking"}), supports=_supports,
                         integrators=INTEGRATORS)
