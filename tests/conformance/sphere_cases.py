"""The contact cases and exact outcomes shared by the engines' sphere tests (refsim, MuJoCo,
pybullet, pymunk, taichi; tests/conformance/test_conformance_spheres.py and each engine's
test_<engine>_spheres.py): which case holds a variant, its parameters, the exact head-on outcomes
(docs/engine_notes.md#exact-head-on-collision-outcomes) and the accuracy row of a run, cached
per process (rows are read, never changed). Imported by basename (tests/engines/conftest.py puts
this directory on the path)."""
import functools

from refsim.registry import get_case
from refsim.testing import accuracy

# v1 = 1, v2 = -1 m/s head-on: (-e, e) for equal masses; masses 1:3 give (-2, 0) at e = 1 and
# (-1.25, -0.25) at e = 0.5 (Newton's restitution law with momentum conservation)
HEAD_ON = {"head_on": (-1.0, 1.0), "head_on_e0.5": (-0.5, 0.5),
           "head_on_1to3": (-2.0, 0.0), "head_on_1to3_e0.5": (-1.25, -0.25)}
PAIRS = list(HEAD_ON) + ["oblique", "oblique_friction"]


def case_of(variant):
    """Name of the contact case that holds `variant`."""
    if variant == "cradle":
        return "newtons_cradle"
    return "sphere_box" if variant.startswith("box_") else "sphere_pairs"


def params(variant, **over):
    """(the case that holds `variant`, its parameters with `over` applied)."""
    c = get_case(case_of(variant))
    return c, c.variant_params(variant, over)


@functools.lru_cache(maxsize=None)
def _cached(engine, variant, integrator, dt, engine_variant, over):
    return accuracy(case_of(variant), variant, engine, integrator, dt, engine_variant,
                    **dict(over))


def row(engine, variant, integrator, dt=1e-3, engine_variant="", **over):
    """The accuracy row with its trajectory (cached per process: read, never change it)."""
    return _cached(engine, variant, integrator, dt, engine_variant, tuple(sorted(over.items())))
