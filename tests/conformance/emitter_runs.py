"""A run of the sprinkler case (cases/emitter/sprinkler.py) on an engine, observed after
each chunk of steps: shared by tests/conformance/test_conformance_emitter.py and the taichi
emitter tests. Imported by basename (tests/engines/conftest.py puts this directory on the
path)."""
import numpy as np

from refsim_cases.emitter.sprinkler import CASE as EMITTER
from refsim.registry import get_engine


def run(engine, p, integrator, dt, formulation, chunks):
    """({observable: array stacked over the start and each chunk's end}, settings): Sim.step(n)
    for each n in `chunks`."""
    sim = get_engine(engine).build(EMITTER.scene(p), dt, integrator, formulation)
    out = [sim.observe()]
    for n in chunks:
        sim.step(n)
        out.append(sim.observe())
    settings = sim.settings()
    sim.close()
    return {k: np.array([o[k] for o in out]) for k in out[0]}, settings
