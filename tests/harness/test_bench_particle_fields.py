"""`refsim bench particle_fields --quick`: the LJ rows agree numpy vs taichi to round-off, the
cell list's cost exponent is near linear, and the figures pass the store's checks."""
import numpy as np
import pytest

from refsim_benchmarks import lennard_jones as lj
from refsim_benchmarks import particle_fields as bench
from refsim.store.figures import check_figures


def test_lj_rows_count_pairs_and_agree_across_engines():
    rows = lj.lj_rows((1000, 4000), quick=True)
    numpy_rows = [r for r in rows if r["engine"] == "numpy"]
    # ~ pi r_c^2 rho / 2 = 6.9 partners per particle within the cut-off (a jittered lattice)
    for r in numpy_rows:
        assert 5.0 * r["n"] <= r["pairs"] <= 9.0 * r["n"]
    for r in rows:
        if r["engine"] == "taichi":
            # the two sum ~14 pair forces (|F| <= ~100 at r >= 0.97) in another order
            assert r["max_abs_diff_vs_numpy"] <= 14 * 100 * 4 * np.finfo(float).eps


def test_cost_exponent_fits_the_slope():
    rows = [{"engine": "numpy", "n": n, "seconds_per_eval": 2e-6 * n ** 1.1}
            for n in (1e3, 1e4, 1e5)]
    assert lj.cost_exponent(rows, "numpy") == pytest.approx(1.1, rel=1e-12)
    assert np.isnan(lj.cost_exponent(rows, "taichi"))


def test_quick_bench_figures_pass_the_store_checks(capsys):
    figures = check_figures(bench.main(quick=True), "particle_fields")
    names = {f["figure"] for f in figures}
    assert {"lj_cell_list_1000", "lj_cell_list_10000", "lj_cell_list_cost_exponent"} <= names
    out = capsys.readouterr().out
    assert "Lennard-Jones, cell list" in out and "cost exponent" in out
