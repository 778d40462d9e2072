"""pytest plugin `refsim` (entry point `pytest11`): the `refsim_engine` marker.

A test function taking the argument `refsim_job` and marked

    @pytest.mark.refsim_engine(MyEngine)                 # or "my_engine", or an instance
    def test_my_engine(refsim_job):                      # cases=["free_fall"] narrows it
        refsim.testing.check(refsim_job)

runs once per job of `refsim.testing.suite(engine, cases)`: every case x variant x engine
variant x integrator the engine supports, at the case's reference dt, with the id
`case/variant[-engine variant]-integrator`. A failure names the error, the case's tolerance and
the tolerance's reason. `refsim.testing.engine_suite` builds the same test in one line and
needs no plugin.

The plugin is loaded in every pytest session of an environment where refsim is installed: it
imports nothing heavy (numpy, pandas, the cases, the engines) until a marked test is collected.
"""
from __future__ import annotations

MARKER = "refsim_engine"
ARGUMENT = "refsim_job"


def pytest_configure(config):
    config.addinivalue_line(
        "markers", f"{MARKER}(engine, cases=None): run the test once per refsim tolerance job "
                   f"of engine (a registered name, an Engine subclass or an instance), passed "
                   f"as the argument {ARGUMENT!r}")


def pytest_generate_tests(metafunc):
    marker = metafunc.definition.get_closest_marker(MARKER)
    if marker is None:
        return
    if ARGUMENT not in metafunc.fixturenames:
        raise ValueError(f"a test marked {MARKER} must take the argument {ARGUMENT!r}: "
                         f"{metafunc.function.__name__}")
    from refsim.testing import suite_params

    metafunc.parametrize(ARGUMENT, suite_params(*marker.args, **marker.kwargs))
