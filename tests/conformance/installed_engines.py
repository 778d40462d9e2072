"""The engine under test for the conformance modules: a registered engine whose package must be
installed. CI must have every engine (.ci/run checks the imports), so a missing package fails
the tests of that engine, never skips them (the per-engine test files import their package at
module level for the same reason); the other engines' parameters still run. Imported by
basename (tests/engines/conftest.py puts this directory on the path; pytest puts it there for
the modules in it)."""
from refsim.registry import get_engine

BUILT_IN = ("refsim", "pybullet", "mujoco", "pymunk", "taichi")


def installed(name):
    """The registered engine `name`; AssertionError when its package does not import."""
    engine = get_engine(name)
    assert engine.available(), f"{name} is not installed: CI must have every engine (fail, " \
                               f"never skip)"
    return engine
