"""Hydrostatic tank on the in-house WCSPH at coarse resolution: the settled bed pressure is
rho0 g H, the water stays at rest and in the tank."""
import numpy as np
import pytest

from refsim.registry import get_case
from refsim.scene import FluidBlock
from refsim.testing import accuracy

CASE = get_case("hydrostatic_tank")


@pytest.mark.slow
def test_hydrostatic_tank_settles_to_rho_g_h():
    p = CASE.variant_params("hydrostatic", {"resolution": 10})
    row = accuracy("hydrostatic_tank", "hydrostatic", "refsim", "velocity_verlet",
                   CASE.reference_dt(p), resolution=10)
    assert row["status"] == "ok"
    assert (row["consistency"] == "consistent"), (row["err_max"], row["tol_reason"])  # <p_bed> within 5 %
    assert row["err_max"] <= 0.05
    assert row["density_drift"] < 0.01
    assert row["velocity_max"] < 0.05  # of sqrt(g H): at rest up to acoustic noise
    # same operations: identical rows (no particle left) of one einsum, the same sum each
    assert row["mass_drift"] == 0.0


def test_tank_is_square_and_closed():
    """Width a, depth H = a: the block fills the tank's width, so nothing is released."""
    p = CASE.variant_params("hydrostatic")
    fluid = CASE.scene(p).part(FluidBlock)
    assert fluid.upper[0] == pytest.approx(p["a"]) and fluid.upper[1] == pytest.approx(p["a"])
    assert fluid.tank_width == pytest.approx(p["a"])


def test_bed_pressure_at_rest_density_is_the_head_below_the_layer():
    """Particles at rest density in the bottom layer read the head of the water above them:
    rho0 g y of the layer plus no Tait pressure (rho = rho0)."""
    p = CASE.variant_params("hydrostatic")
    dx = CASE.spacing(p)
    x = np.array([[0.5 * dx, 0.5 * dx], [1.5 * dx, 0.5 * dx], [0.5 * dx, 1.5 * dx]])
    rho = np.full(3, 1000.0)
    assert CASE.bed_pressure(p, x, rho) == pytest.approx(1000.0 * p["g"] * 0.5 * dx, rel=1e-12)
