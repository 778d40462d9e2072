"""Engine adapters, one package per engine, all behind `refsim.engine.Engine`.

They are found through the `refsim.engines` entry points declared in pyproject.toml
(refsim/registry.py), never imported by the harness core. Package names avoid the engine
packages' own names (a package called `pybullet` would shadow the real one). Engine packages
are imported lazily, inside `build`, never at import time. `refsim_adapters.common` is no engine: it
holds the physics-neutral scene translation every engine shares (refusals, hinges, contact
materials, SPH lattices), written once.
"""
