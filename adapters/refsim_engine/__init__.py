"""The in-house numpy reference engine, `refsim`, behind the same contract as the others.

Its step is built from `scene.features()` only: gravity, drag, springs and joints become force
or constraint stages; nothing else is assembled, and energy is never evaluated while stepping.
`engine`: RefsimEngine (who it is, the integrators it offers, its refusals); `groups/`: one
module per model group it runs (what it claims, supports, its formulations, the sim it builds).
The sims the particles, spheres and sph groups build:
- `stepped`: the base of the sims run by a `refsim.integrators` stepper;
- `particles`: ParticleSim (free particles, springs, drag; rods as KKT or penalty springs);
- `hinges`: HingeSim (rods in generalized coordinates, one angle per rod);
- `contacts`: ContactSim (spheres and walls with impulses, three formulations);
- `sph`: FluidSim (2D weakly compressible SPH in a tank).
Scene translation shared with the other engines (refusals, hinge frames, rod errors, SPH
lattices) is in `refsim_adapters.common`.
"""
from .engine import RefsimEngine

__all__ = ["RefsimEngine"]
