"""Engine adapters, one module per engine, all behind `refsim.engine.Engine`.

Module names avoid the engine packages' own names (a file called `pybullet.py` would shadow
the real package). Engine packages are imported lazily, inside `build`, never at import time.
"""
from __future__ import annotations

import importlib

# name -> "module:Class"; the order is the order of the report's columns
_REGISTRY = {
    "refsim": "adapters.refsim_engine:RefsimEngine",
    "pybullet": "adapters.pybullet_engine:PybulletEngine",
    "mujoco": "adapters.mujoco_engine:MujocoEngine",
    "pymunk": "adapters.pymunk_engine:PymunkEngine",
    "taichi": "adapters.taichi_engine:TaichiEngine",
}


def register(name: str, target: str) -> None:
    _REGISTRY[name] = target


def engine_names() -> list[str]:
    return list(_REGISTRY)


def get_engine(name: str):
    if name not in _REGISTRY:
        raise ValueError(f"engine must be one of {list(_REGISTRY)}, got {name!r}")
    module, _, cls = _REGISTRY[name].partition(":")
    return getattr(importlib.import_module(module), cls)()
