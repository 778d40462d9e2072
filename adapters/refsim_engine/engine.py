"""RefsimEngine: who the in-house engine is. What it runs is its model groups (groups/: one
module each, particles, spheres and sph among them); what it refuses, and why, is `refusals`."""
from __future__ import annotations

from refsim.engine import Engine
from refsim.integrators import INTEGRATORS


class RefsimEngine(Engine):
    name = "refsim"
    dims = (2, 3)
    # every stepper but the implicit midpoint rule, which only the rigid group offers (its
    # point there: bounded L and E on a tumbling body); on the particle scenes it would add a
    # ninth of the refsim rows to the default run and show nothing Verlet's rows do not
    integrators = tuple(name for name in INTEGRATORS if name != "implicit_midpoint")
    reference = True  # the in-house reference simulator: listed and reported first
    refusals = {
        "rigid_shapes": "refsim has no frictional rigid-body contact (the slides' rigid-body "
                        "model has none: Newton-Euler and the orientation only)"}

    def version(self) -> str:
        from refsim import __version__
        return __version__
