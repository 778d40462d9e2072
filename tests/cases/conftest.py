"""Fixtures the case tests share."""
from types import SimpleNamespace

import pytest


@pytest.fixture
def stress_limits(tmp_path):
    """limits(case, variant, integrators) -> the `refsim stress --case` limits table on the
    in-house engine, indexed by integrator (stored under tmp_path)."""
    from refsim.stress import limits_table, options

    def limits(case, variant, integrators):
        args = SimpleNamespace(case=case, variant=variant, engine=["refsim"],
                               integrator=list(integrators), periods=None, dt=None,
                               quick=False, out=str(tmp_path))
        opts = options(args)
        return limits_table(opts, opts["probe"]).set_index("integrator")
    return limits
