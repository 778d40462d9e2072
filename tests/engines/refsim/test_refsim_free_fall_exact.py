"""The slides' free-fall results, from the steppers through the in-house engine, to 1e-12."""
import numpy as np
import pytest

from refsim.registry import get_engine
from refsim.registry import get_case
from refsim.integrators import get_integrator

DT, STEPS = 1e-3, 1000
FIRST_ORDER = {"explicit_euler": -1, "symplectic_euler_dk": -1, "implicit_euler": +1,
               "symplectic_euler": +1, "baraff_witkin": +1}  # sign s of k(k+s)/2


def _heights(integrator):
    case = get_case("free_fall")
    p = case.variant_params("default")
    sim = get_engine("refsim").build(case.scene(p), DT, integrator)
    z = []
    for _ in range(STEPS):
        sim.step(1)
        z.append(sim.observe()["x"][0, 2])
    return p, np.array(z)


@pytest.mark.parametrize("name", [n for n in get_engine("refsim").integrators
                                  if n != "dopri5_adaptive"])
def test_free_fall_heights_equal_each_steppers_discrete_closed_form(name):
    p, z = _heights(name)
    k = np.arange(1, STEPS + 1)
    z0, v0, g = p["height"], p["vz0"], p["g"]
    if get_integrator(name).order == 1:
        s = FIRST_ORDER[name]
        expected = z0 + k * DT * v0 - k * (k + s) / 2 * DT ** 2 * g
    else:  # every second-order (or higher) method is exact on a quadratic
        expected = z0 + k * DT * v0 - 0.5 * (k * DT) ** 2 * g
    np.testing.assert_allclose(z, expected, rtol=1e-12, atol=0)


def test_semi_implicit_error_is_g_t_dt_over_2():
    p, z = _heights("symplectic_euler")
    t = DT * STEPS
    exact = p["height"] + p["vz0"] * t - 0.5 * p["g"] * t * t
    assert z[-1] - exact == pytest.approx(-p["g"] * t * DT / 2, rel=1e-9)
