"""Dam break on the in-house WCSPH at coarse resolution: the surge front against Martin & Moyce
(1952), the front definition, and the front figure the case declares for the report."""
import numpy as np
import pytest

from refsim_cases._martin_moyce import DATA, clock_spread_rms, martin_moyce
from refsim.registry import get_case
from refsim.testing import accuracy

CASE = get_case("dam_break")


def test_data_file_carries_its_source_and_the_table():
    head = DATA.read_text().splitlines()[0]
    assert head.startswith("# Source: Martin & Moyce (1952)")
    T, Z = martin_moyce()
    assert len(T) == 25 and T[2] == pytest.approx(1.19) and Z[2] == pytest.approx(1.44)
    assert np.all(np.diff(T) > 0) and np.all(np.diff(Z) > 0)


def test_data_file_is_installed_as_package_data():
    from importlib.resources import files
    packaged = files("cases") / "data" / DATA.name
    assert packaged.is_file() and packaged.read_text() == DATA.read_text()


@pytest.mark.slow
def test_front_against_martin_moyce_at_coarse_resolution():
    """At a/dx = 10 (200 particles) the front must lie within the experiment's own 10 % spread
    in T (RMS 0.66 in Z, computed from the table), with the fitted time shift inside its
    bound, and the density within 3 % everywhere (issue 5). Measured: front_err_rms 0.63,
    density_dev_max 0.75 %. The case tolerance (0.15, the experiment's 5-10 % spread) is for
    the finer runs; the front error there is set by the numerical bed friction (the case
    docstring), not by a discretisation error that shrinks as dx."""
    p = CASE.variant_params("res20", {"resolution": 10})
    row = accuracy("dam_break", "res20", "refsim", "velocity_verlet", CASE.reference_dt(p),
                   resolution=10)
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


def test_release_declares_the_surge_front_figure_over_martin_moyce():
    """The report draws each run's front Z(T), shifted by its fitted time shift, over the
    measured points, with the labels the report has always used."""
    T, Z = martin_moyce()
    for variant in CASE.variants:
        (figure,) = CASE.figures(CASE.variant_params(variant))
        assert (figure["kind"], figure["x"], figure["y"]) == ("trace_over_data", "T", "front")
        assert figure["title"] == "surge front"
        assert figure["x_shift_column"] == "time_shift"
        assert figure["x_label"] == "T = t sqrt(2 g / a)  (+ fitted shift)"
        assert figure["y_label"] == "Z = x / a"
        assert figure["data"]["label"] == "Martin & Moyce (1952), Table 2"
        assert figure["data"]["x"] == T.tolist() and figure["data"]["y"] == Z.tolist()


def test_release_series_carry_the_figure_axes():
    """The stored series (1-D observables) hold the figure's x and y keys."""
    p = CASE.variant_params("res20", {"resolution": 6, "t_end_T": 1.5})
    row = accuracy("dam_break", "res20", "refsim", "velocity_verlet", CASE.reference_dt(p),
                   resolution=6, t_end_T=1.5)
    (figure,) = CASE.figures(p)
    assert row["status"] == "ok"
    assert len(row["series"][figure["x"]]) == len(row["series"][figure["y"]]) > 1
    assert figure["x_shift_column"] in row
