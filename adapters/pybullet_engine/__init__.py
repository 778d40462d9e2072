"""pybullet (Bullet's Featherstone multibody, in DIRECT mode) behind the refsim contract.

One module per concern: runtime (the lazy import, the stepper's description, state reads),
multibodies (point masses and bodies on rods, no contacts), forces (springs and drag as
external forces), contacts (rigid spheres and walls), sim (the Sim: world, step, observe,
settings), engine (the Engine: parts, refusals, build). The facts each applies, measured on
pybullet 3.2.7, are in that module's docstring.
"""
from .engine import PybulletEngine
from .sim import PybulletSim

__all__ = ["PybulletEngine", "PybulletSim"]
