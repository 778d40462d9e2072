"""The report's overview (scoreboard cells from hand-made rows) and its figure style
(engine colours, integrator markers, small multiples, the round-off band)."""
import math

import numpy as np
import pandas as pd
import pytest

from refsim.report import style as rs
from refsim.report.overview import cell, scoreboard

COLUMNS = ["engine", "engine_variant", "integrator", "dt", "status", "reason", "err_max",
           "step_s", "consistency"]


def _rows(*rows):
    return pd.DataFrame(rows, columns=COLUMNS)


def test_cell_reaches_the_target_with_its_cheapest_row():
    rows = _rows(("e", "", "rk4", 0.01, "ok", "", 1e-6, 0.30, "consistent"),
                 ("e", "", "euler", 0.001, "ok", "", 1e-5, 0.20, "consistent"),
                 ("e", "", "euler", 0.01, "ok", "", 1e-2, 0.02, "consistent"),
                 ("e", "", "rk4", 0.1, "diverged", "nan", np.nan, 0.01, ""))
    got = cell(rows, "err_max", 1e-4)
    assert got["verdict"] == "reaches the target" and got["best"] == 1e-6
    assert got["cheapest"] == "euler at dt = 0.001 s" and got["run_time"] == 0.20
    assert got["best_at"] == "rk4 at dt = 0.01 s"
    assert got["method"] == "3 consistent" and got["inconsistent"] == 0


def test_cell_short_of_the_target_names_the_best_error_and_where():
    rows = _rows(("e", "f", "rk4", 0.01, "ok", "", 1e-2, 0.3, "consistent"))
    got = cell(rows, "err_max", 1e-4)
    assert (got["verdict"], got["best"], got["cheapest"]) == ("does not reach the target",
                                                              1e-2, "")
    assert got["best_at"] == "rk4:f at dt = 0.01 s"


def test_target_and_method_are_answered_apart():
    """A row reaching the target while inconsistent with its method (an accurate engine
    whose rk4 is not RK4) shows both answers: the target's word, the inconsistent count."""
    rows = _rows(("e", "", "rk4", 0.01, "ok", "", 1e-6, 0.3, "inconsistent"),
                 ("e", "", "rk4", 0.02, "ok", "", 0.10, 0.2, "unresolved"),
                 ("e", "", "own", 0.02, "ok", "", 0.10, 0.2, "no method reference"))
    rows["consistency_reason"] = ["error 1e-06 above the method's bound 1e-08 (100x)", "", ""]
    got = cell(rows, "err_max", 1e-4)
    assert got["verdict"] == "reaches the target" and got["inconsistent"] == 1
    assert got["method"] == ("1 inconsistent (first: rk4 at dt = 0.01 s: error 1e-06 above "
                             "the method's bound 1e-08 (100x)), 1 unresolved, 1 no method "
                             "reference")


def test_unsupported_and_failed_cells_carry_their_reason():
    unsupported = _rows(("e", "", "", np.nan, "unsupported", "e does not simulate fluid",
                         np.nan, np.nan, ""))
    got = cell(unsupported, "err_max", 1e-4)
    assert (got["verdict"], got["note"]) == ("unsupported", "e does not simulate fluid")
    failed = _rows(("e", "", "rk4", 0.1, "failed", "ZeroDivisionError", np.nan, np.nan, ""))
    got = cell(failed, "err_max", 1e-4)
    assert (got["verdict"], got["note"]) == ("not run", "failed: ZeroDivisionError")


class _Definitions:
    def of_row(self, row):
        return {"case": row["case"], "variant": row["variant"], "tolerance_column": "err_max",
                "target_error": 1e-4, "error_floor": 1e-12}


def test_scoreboard_has_one_row_per_case_variant_and_engine():
    rows = _rows(("a", "", "rk4", 0.01, "ok", "", 1e-6, 0.3, "consistent"),
                 ("b", "", "rk4", 0.01, "ok", "", 1e-2, 0.1, "inconsistent"),
                 ("a", "", "rk4", 0.02, "ok", "", 1e-5, 0.1, "consistent"))
    table = pd.concat([rows.assign(case="c1"), rows.assign(case="c2")]).assign(
        variant="v", params="{}")
    board = scoreboard(table, _Definitions())
    assert list(zip(board["case"], board["engine"], board["verdict"])) == [
        ("c1 / v", "a", "reaches the target"), ("c1 / v", "b", "does not reach the target"),
        ("c2 / v", "a", "reaches the target"), ("c2 / v", "b", "does not reach the target")]
    assert list(board["best"]) == [1e-6, 1e-2, 1e-6, 1e-2]
    assert board["cheapest"].iloc[0] == "rk4 at dt = 0.02 s"


def test_one_colour_per_engine_and_one_style_per_integrator():
    table = pd.DataFrame({"engine": ["zeta", "alpha", "zeta", "mid"],
                          "integrator": ["rk4", "euler", "", "rk2"]})
    style = rs.Style.of_table(table)
    assert style.engines == ["alpha", "mid", "zeta"] and style.integrators == ["euler", "rk2",
                                                                              "rk4"]
    colours = [style.colour(e) for e in ("alpha", "mid", "zeta")]
    assert len(set(colours)) == 3 and style.colour("zeta") == colours[2]
    many = rs.Style(integrators=[f"i{k}" for k in range(40)])
    assert len({many.marker(f"i{k}") for k in range(40)}) == 40


def test_small_multiples_hold_at_most_max_series():
    series = ([("big", form, f"i{k}") for form in ("f1", "f2") for k in range(14)]
              + [("small", "", f"i{k}") for k in range(5)])
    facets = rs.panels(series)
    assert all(len(members) <= rs.MAX_SERIES for _, members in facets)
    assert sorted(s for _, members in facets for s in members) == sorted(series)
    assert [name for name, _ in facets] == ["big:f1 (1/2)", "big:f1 (2/2)", "big:f2 (1/2)",
                                            "big:f2 (2/2)", "small"]


def test_errors_at_or_below_the_floor_go_on_the_band_never_dropped():
    moved = rs.on_band([0.0, 1e-12, 5e-13, 2e-12, 1e-3], 1e-12)
    assert np.all(np.isfinite(moved)) and len(moved) == 5
    # the band is 1e-12 * 10 ** -1 (libm's pow: within 2 ulps of 1e-13 on any machine)
    np.testing.assert_allclose(moved[:3], [1e-13] * 3, rtol=4.5e-16, atol=0)
    assert moved[0] == moved[1] == moved[2] and list(moved[3:]) == [2e-12, 1e-3]
    assert rs.floor_of(1e-11, [0.0]) == 1e-11
    assert rs.floor_of(0.0, [0.0, 1e-9, 1e-6]) == pytest.approx(1e-10)
    assert rs.floor_of(math.nan, [0.0]) == 1e-16
