"""taichi (1.7.4) behind the refsim contract: the steppers are taichi kernels written here.

One module per concern:
- engine: `TaichiEngine`, who the engine is (dimensions, steppers, the refusals table);
- groups: the model groups, one module each (particles, spheres, sph, rigid, pivots, ...): the
  scenes each claims, its refusals, formulations and Sims;
- runtime: taichi imported and initialised once per process (docs/engine_notes.md#taichi
  fixes: no version check, f64, one thread, no fast math, no offline cache), kernels made once;
- sim: `KernelSim`, the bookkeeping every system shares (compile timing, in-kernel time
  loop or one launch per step, settings);
- forces: the particles_t argpack (gravity, drag, springs to anchors) the particles and
  spheres groups share (kernels in particle_kernels: three steppers, one signature);
- the kernels of the groups: contact_detection and contact_kernels (spheres), sph_physics and
  sph_kernels (sph), rigid_kernels, pivot_kernels, ... .
Importing this package does not import taichi: that happens in `available()` and the first
`build`. The kernel modules (and kernel_types) initialise taichi when imported.
"""
from .engine import TaichiEngine

__all__ = ["TaichiEngine"]
