"""taichi (1.7.4) behind the refsim contract: the steppers are taichi kernels written here.

One module per concern:
- engine: `TaichiEngine` (parts, features, refusals, which Sim runs a scene);
- runtime: taichi imported and initialised once per process (docs/engine_notes.md#taichi
  fixes: no version check, f64, one thread, no fast math, no offline cache), kernels made once;
- sim: `KernelSim`, the bookkeeping every system shares (compile timing, in-kernel time
  loop or one launch per step, settings);
- particles: point masses with gravity, drag and springs to anchors; hinged rods in
  generalized coordinates (kernels in particle_kernels: three steppers, one signature);
- spheres: colliding spheres with impulse contacts (kernels in contact_detection,
  contact_kernels);
- sph: 2D weakly compressible SPH (kernels in sph_physics, sph_kernels).
Importing this package does not import taichi: that happens in `available()` and the first
`build`. The kernel modules (and kernel_types) initialise taichi when imported.
"""
from .engine import TaichiEngine

__all__ = ["TaichiEngine"]
