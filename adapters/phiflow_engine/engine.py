"""PhiflowEngine: who the PhiFlow peer is (name, package, dimensions, its integrators) and why
it refuses every scene kind but the grid fluids (`refusals`). What it runs is its one model
group, adapters/phiflow_engine/groups/grid_fluids.py."""
from __future__ import annotations

from refsim.engine import Engine, installed_version

from .groups.grid_fluids import INTEGRATORS

SENTENCE = ("PhiFlow peer: runs only the grid-fluid cases (the lid-driven cavity and "
            "Taylor-Green on a MAC grid)")
# every part kind refsim's scenes hold but the fluid grid (refsim/scene: each module's kind)
OTHER_KINDS = ("emitter", "flocking", "fluid", "gravity_pairs", "grids", "joints",
               "lennard_jones", "meshes", "networks", "particles", "prescribed_flow", "rigid",
               "rigid_pivots", "rigid_shapes", "springs", "surface_sampling", "velocity_field",
               "walls")


class PhiflowEngine(Engine):
    name = "phiflow"
    package = "phi"  # the import name; the distribution is `phiflow` (version())
    peer = True  # the cavity and Taylor-Green only: `refsim run --engine phiflow ...`
    dims = (2,)
    integrators = INTEGRATORS
    refusals = {kind: SENTENCE for kind in OTHER_KINDS}

    def version(self) -> str:
        """The `phiflow` distribution's version (the package imports as `phi`)."""
        return installed_version("phiflow")
