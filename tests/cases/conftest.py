"""Fixtures the case tests share."""
from types import SimpleNamespace

import pytest


@pytest.fixture
def stress_limits(tmp_path):
    """limits(case, variant, integrators) -> the `refsim stress --case` limits table on the
    in-house engine, indexed by integrator (stored under tmp_path)."""
    from refsim.stress.limits import limits_table, options

    def limits(case, variant, integrators):
        args = SimpleNamespace(case=case, variant=variant, engine=["refsim"],
                               integrator=list(integrators), periods=None, dt=None,
                               quick=False, out=str(tmp_path))
        opts = options(args)
        return limits_table(opts, opts["probe"]).set_index("integrator")
    return limits


@pytest.fixture(scope="module")
def planted():
    """The planted-defect engines (adapters.planted_defects) registered as "planted_<defect>"
    for the module's tests (run_job looks engines up by name), unregistered after them."""
    from refsim_adapters.planted_defects.engines import register_all
    from refsim.registry import unregister
    names = register_all()
    yield names
    for name in names:
        unregister("engine", name)


@pytest.fixture
def rk_step_deviation():
    """deviation(case, p, dt, tableau) -> the largest distance, over the run's sampled steps k
    and its particles, between the explicit RK step matrix on p' = M (p - c) written from the
    tableau (refsim.expected's _rk_matrix) raised to the k and the flow's exp(M k dt), applied
    to the particles' offsets from the centre (an affine field case: `field`, `relative_start`,
    `sampled_steps`)."""
    import numpy as np
    from scipy.linalg import expm

    from refsim.expected import _rk_matrix

    def deviation(case, p, dt, tableau):
        matrix, rel = case.field(p).matrix(), case.relative_start(p)
        step = _rk_matrix(tableau, matrix, dt)
        return max(np.max(np.linalg.norm(rel @ (np.linalg.matrix_power(step, int(k))
                                                - expm(matrix * k * dt)).T, axis=1))
                   for k in case.sampled_steps(p, dt))
    return deviation
