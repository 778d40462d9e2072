"""The in-house engine's Lennard-Jones group: particles under the pair forces of a LennardJones
part (refsim.models.lennard_jones), pairs found by a cell list (refsim.models.cell_list) when
the cut-off is finite, all pairs when it is inf; open space or a periodic box; 2D (the plane
z = 0) or 3D. Stepped by the fixed-step refsim.integrators steppers: velocity Verlet (the MD
standard), symplectic Euler, RK4 and explicit Euler (whose energy drifts).

Observes x (n, 3) (unwrapped: a periodic box wraps positions only inside the force
evaluation), v (n, 3), and the extra `momentum` (3,) kg m/s, sum m v (conserved to round-off:
the pair force is antisymmetric).
"""
from __future__ import annotations

import math

import numpy as np

from refsim_adapters.common.particle_fields import supports_scene
from refsim.engine import ModelGroup
from refsim.integrators import get_integrator
from refsim.models.lennard_jones import LennardJonesModel, LennardJonesSystem
from refsim.scene.lennard_jones import LennardJones
from refsim.scene import Particles

from ..stepped import SteppedSim

INTEGRATORS = ("velocity_verlet", "symplectic_euler", "rk4", "explicit_euler")


class LennardJonesSim(SteppedSim):
    def __init__(self, scene, dt, stepper):
        self.scene, self.part = scene, scene.part(LennardJones)
        bodies = scene.part(Particles)
        system = LennardJonesSystem(bodies.mass, LennardJonesModel.of_part(self.part),
                                    scene.dim)
        super().__init__(dt, stepper, system, np.array(bodies.position).reshape(-1),
                         np.array(bodies.velocity).reshape(-1))

    def stages(self):
        return self.system.stages() + [f"integrate:{self.stepper.name}"]

    def _observe(self):
        x, v = self.coordinates()
        v = v.reshape(-1, 3)
        return {"x": x.reshape(-1, 3), "v": v,
                "momentum": np.sum(self.system.masses[:, None] * v, axis=0)}

    def settings(self):
        part = self.part
        return {**self.base_settings(), "epsilon": part.epsilon, "sigma": part.sigma,
                "cutoff": part.cutoff if math.isfinite(part.cutoff) else "inf",
                "shift": part.shift, "box": list(part.box) if part.box else None,
                "dim": self.scene.dim,
                "pair_search": ("all pairs (no cut-off)" if math.isinf(part.cutoff) else
                                "cell list, cells of side >= cutoff, one vectorised pass per "
                                "neighbour-cell offset" + (", minimum image" if part.box
                                                           else ""))}


def claims(scene) -> bool:
    """Particles and a LennardJones part, nothing else."""
    return scene.part_kinds() == {"particles", "lennard_jones"} and scene.contact is None


def _supports(engine, scene, integrator):
    return supports_scene(scene, "refsim")


def _build(engine, scene, dt, integrator, formulation):
    return LennardJonesSim(scene, dt, get_integrator(integrator))


MODEL_GROUP = ModelGroup(name="lennard_jones", build=_build, claims=claims,
                         parts=frozenset({"particles", "lennard_jones"}),
                         features=frozenset({"lennard_jones"}), supports=_supports,
                         integrators=INTEGRATORS)
