"""pybullet (Bullet's Featherstone multibody, in DIRECT mode) behind the refsim contract.

One module per concern: runtime (the lazy import, the stepper's description, state reads),
multibodies (point masses and bodies on rods, no contacts), forces (springs and drag as
external forces), contacts (rigid spheres and walls), sim (the Sim the particles and spheres
groups share: world, step, observe, settings), softbody (a spring network as pybullet's soft
body), engine (the Engine: who it is and its refusals) and groups/ (the model groups: what it
runs). The facts each applies, measured on pybullet 3.2.7, are in that module's docstring.
"""
from .engine import PybulletEngine
from .sim import PybulletSim

__all__ = ["PybulletEngine", "PybulletSim"]
