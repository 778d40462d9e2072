"""taichi Sims hold the arrays Python reads as numpy arrays the kernels write in place
(kernel_store.to_ndarray): observe() must hand out copies, and settings must say so."""
from __future__ import annotations

import numpy as np
import pytest

from refsim.registry import get_case, get_engine

TAICHI = get_engine("taichi")
# one case per taichi Sim class
CASES = {"free_fall": "ParticleSim", "pendulum": "HingeSim", "sphere_pairs": "SphereSim",
         "hydrostatic_tank": "FluidSim", "dzhanibekov": "RigidSim", "heavy_top": "PivotSim",
         "kepler": "GravitySim", "lj_dimer": "LennardJonesSim",
         "advection_vortex": "AffineFieldSim", "sphere_sampling": "SphereSamplingSim",
         "boids": "FlockKernelSim", "sprinkler": "EmitterKernelSim"}


def _build(case):
    c = get_case(case)
    p = c.variant_params(next(iter(c.variants)))
    scene = c.scene(p)
    integrator = next(i for i in TAICHI.offered_integrators(scene)
                      if TAICHI.supports(scene, i) is None)
    return TAICHI.build(scene, c.reference_dt(p), integrator, TAICHI.formulations(scene)[0])


def _held_arrays(sim) -> list:
    """The numpy arrays a Sim holds (attributes, dict values, kernel arguments)."""
    found = []
    for value in vars(sim).values():
        items = value.values() if isinstance(value, dict) else \
            value if isinstance(value, tuple) else (value,)
        found += [v for v in items if isinstance(v, np.ndarray)]
    return found


@pytest.mark.parametrize("case", sorted(CASES))
def test_observe_hands_out_copies(case):
    sim = _build(case)
    assert type(sim).__name__ == CASES[case]
    sim.step(3)
    first = sim.observe()
    kept = {k: np.array(v, copy=True) for k, v in first.items() if isinstance(v, np.ndarray)}
    held = _held_arrays(sim)
    assert held, "the Sim holds its state as numpy arrays"
    for name in kept:
        assert not any(np.shares_memory(first[name], a) for a in held), name
    sim.step(5)
    for name, before in kept.items():  # the kernels wrote the state; the observation stayed
        assert np.array_equal(first[name], before, equal_nan=True), name
    later = sim.observe()
    assert not np.array_equal(later["x"], first["x"]), "the state moved (test not vacuous)"
    arrays = sim.settings()["arrays"]
    assert "numpy arrays handed to the kernels as external arrays" in arrays
