"""PhiFlow (PyPI `phiflow`, imported as `phi`; measured on phiflow 3.4.0, phiml 1.16.1, numpy
backend) behind the refsim engine contract, as an optional peer on the grid fluids: the
lid-driven cavity and Taylor-Green, stepped PhiFlow's own way (semi-Lagrangian or MacCormack
advection, its diffusion, `fluid.make_incompressible` with an explicit CG `Solve`) on a
`StaggeredGrid` in float64. Not in the `engines` extra (the default install does not grow):
`pip install -e ".[peers]"` adds it; without it the engine is listed as unavailable and its rows
say "phi is not installed", as for any engine whose package is missing.

Modules: `engine` (PhiflowEngine: who it is, its refusals), `staggered` (refsim's MAC face
arrays <-> PhiFlow's staggered component arrays, the boundary), `groups/grid_fluids.py` (the
group: support, the step, observation, settings). docs/engine_notes.md#phiflow has the facts
measured.
"""
from .engine import PhiflowEngine

__all__ = ["PhiflowEngine"]
