"""Dam break on the in-house WCSPH at coarse resolution: the hydrostatic tank and the surge
front against Martin & Moyce (1952)."""
import numpy as np
import pytest

from refsim.registry import get_case
from cases.dam_break import clock_spread_rms, martin_moyce
from refsim.testing import accuracy

CASE = get_case("dam_break")


def _run(variant, **params):
    p = CASE.variant_params(variant, params)
    return p, accuracy("dam_break", variant, "refsim", "velocity_verlet", CASE.reference_dt(p),
                       **params)


def test_data_file_carries_its_source_and_the_table():
    from cases.dam_break import DATA
    head = DATA.read_text().splitlines()[0]
    assert head.startswith("# Source: Martin & Moyce (1952)")
    T, Z = martin_moyce()
    assert len(T) == 25 and T[2] == pytest.approx(1.19) and Z[2] == pytest.approx(1.44)
    assert np.all(np.diff(T) > 0) and np.all(np.diff(Z) > 0)


def test_hydrostatic_tank_settles_to_rho_g_h():
    p, row = _run("hydrostatic", resolution=10)
    assert row["status"] == "ok"
    assert row["within_tol"], (row["err_max"], row["tol_reason"])  # <p_bed> within 5 %
    assert row["density_drift"] < 0.01
    assert row["velocity_max"] < 0.05  # of sqrt(g H): at rest up to acoustic noise
    assert row["mass_drift"] == 0.0


def test_front_against_martin_moyce_at_coarse_resolution():
    """At a/dx = 10 (200 particles) the front must lie within the experiment's own 10 % spread
    in T (RMS 0.66 in Z, computed from the table), with the fitted time shift inside its
    bound, and the density within 3 % everywhere (issue 5). Measured: front_err_rms 0.63,
    density_dev_max 0.75 %. The case tolerance (0.15, the experiment's 5-10 % spread) is for
    the finer runs; the front error there is set by the numerical bed friction (the case
    docstring), not by a discretisation error that shrinks as dx."""
    p, row = _run("res20", resolution=10)
    assert row["status"] == "ok" and row["mass_drift"] < 0.01
    assert abs(row["time_shift"]) <= 0.3
    assert row["density_dev_max"] < 0.03
    assert row["front_err_rms"] < clock_spread_rms(0.10), row["front_err_rms"]


def test_front_definition_ignores_spray():
    """A lone particle far ahead of the surge does not move the front."""
    p = CASE.variant_params("res20")
    dx = CASE.spacing(p)
    sheet = np.stack(np.meshgrid(np.arange(0, 3 * p["a"], dx) + dx / 2,
                                 np.arange(3) * dx + dx / 2), -1).reshape(-1, 2)
    spray = np.array([[8 * p["a"], dx / 2]])
    assert CASE.front(p, sheet) == pytest.approx(CASE.front(p, np.vstack([sheet, spray])))
    assert CASE.front(p, sheet) == pytest.approx((3 * p["a"] - dx / 2) / p["a"], abs=dx / p["a"])
