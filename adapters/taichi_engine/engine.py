"""The taichi engine: who it is (name, package, dimensions, steppers) and why it refuses what no
model group runs (`refusals`). What it runs is its model groups (groups/): particles, spheres,
sph, rigid, pivots, gravity_pairs, lennard_jones, flocking, emitter, first_order_fields,
spring_network, grid_evolution, grid_poisson, fem, grid_fluids."""
from __future__ import annotations

from refsim.engine import Engine

from .runtime import THREADS, import_taichi
from .sim import INTEGRATORS

WHO = "taichi adapter"  # how the reasons name this engine
# the formulation whose stages run on the process's threads (groups/sph.py): on one thread it
# is the serial kernel's arithmetic launched once per step
THREADED_FORMULATION = "parallel"


class TaichiEngine(Engine):
    name = "taichi"
    package = "taichi"
    dims = (2, 3)
    integrators = INTEGRATORS
    refusals = {
                "plates": "taichi's sphere kernels collide spheres with planes only: thin "
                          "plates (finite slabs, the tunnelling case) are not written",
                # the collision queries (issue 28): no collision, BVH or SDF API in taichi (only
                # sorting and prefix sums); kernels for them are not written
                **dict.fromkeys(("polygon_pairs", "box_pairs", "sdf_probes", "bvh_queries",
                                 "sphere_sweeps"),
                                "taichi has no collision-detection API (no SAT, signed distance "
                                "field, BVH or time-of-impact query; only sorting and prefix "
                                "sums), and refsim has not written kernels for these queries"),"rigid_shapes": "taichi's rigid kernels have no frictional contact (they "
                                "follow the slides' rigid-body model: Newton-Euler and the "
                                "orientation)",
                "prescribed_flow": "taichi: the prescribed-flow advection tests (a level set, "
                                   "markers in LeVeque's vortex or Zalesak's rotation) run "
                                   "in-house only; no taichi kernels are written for them"}

    def available(self) -> bool:
        try:
            import_taichi()
        except Exception:
            return False
        return True

    def matrix_formulations(self, scene):
        """Without `parallel` (the sph group's threaded kernel) when taichi runs on one thread
        (THREADS, the default): it is then the serial kernel's arithmetic (bit-identical,
        tested) launched once per step, which adds no physics to the matrix and says nothing
        about parallel speed (30 s of the default run's work); `refsim bench sph` measures the
        threads. A policy of this engine's thread count, read off the formulation names."""
        forms = self.formulations(scene)
        if THREADS == 1:
            return tuple(f for f in forms if f != THREADED_FORMULATION)
        return forms
