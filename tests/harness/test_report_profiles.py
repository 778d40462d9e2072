"""Declared figures beyond time series: a case's profiles kept at the last sample (kind
"profile", the cavity's centrelines against Ghia) and figures shared by several case
sections (`"shared": id`: the cavity's grids on the same axes, the SPH and FLIP dam breaks'
fronts side by side). The drawn lines are compared with the stored series, not just the file."""
import json
import re

import numpy as np
import pandas as pd
import pytest

from refsim.report import build, plots
from refsim.report import style as rs
from refsim.run import runner
from refsim.run.job import Job, PROFILE_POINTS, profile_names, run_job, series
from refsim.store.results import RunStore, load_series, new_run_id, row_key
from refsim.store.definitions import Definitions, for_jobs

T_END = 0.5  # s: a short march (8 steps at n = 16, 16 at n = 32); the figure, not Ghia, is
# what is checked here


@pytest.fixture(scope="module")
def cavity_run(tmp_path_factory):
    """The cavity at n = 16 and 32 (variants default and n32), refsim sl_linear at the
    reference dt, stored and reported."""
    jobs = runner.expand(cases=["cavity"], engines=["refsim"], integrators=["sl_linear"],
                         variants=["default", "n32"], quick=True,
                         params={"cavity": {"t_end": T_END}})
    st = RunStore.create(tmp_path_factory.mktemp("runs"),
                         {"run_id": new_run_id(), "command": "test", "engines": {}})
    st.add_definitions(for_jobs(jobs))  # as `refsim run` does: the report reads these
    runner.run_matrix(jobs, st, repeats=1)
    build.write_report(st.dir)
    return st.dir


def _captured(monkeypatch):
    """The figures `save` writes, kept for inspection (then saved as usual)."""
    saved, original = [], rs.save
    monkeypatch.setattr(rs, "save", lambda fig, *a, **k: saved.append(fig) or original(
        fig, *a, **k))
    return saved


def test_series_keeps_a_declared_profile_at_the_last_sample():
    """The stored profile is the observable's last sample, bit for bit (the same function of
    the same fields), 257 numbers (<= PROFILE_POINTS); the 1-D series are kept as before."""
    from refsim.registry import get_case
    case = get_case("cavity")
    p = case.variant_params("default", {"t_end": T_END})
    job = Job("cavity", "default", "refsim", "direct", "sl_linear", case.reference_dt(p),
              (("t_end", T_END),))
    row = run_job(job, repeats=0, keep_trajectory=True)
    assert row["status"] == "ok", row["reason"]
    observed = case.observables(p, row["trajectory"])
    assert profile_names(case.figures(p)) == ["u_centreline", "v_centreline"]
    for name in ("u_centreline", "v_centreline"):
        assert row["series"][name] == observed[name][-1].tolist()
        assert len(row["series"][name]) == 257 <= PROFILE_POINTS
    assert row["series"]["divergence"] == observed["divergence"].tolist()
    assert "centreline" not in row["series"]  # a vector not declared: no time series of it


class _Stub:
    """The hooks `series` calls, with one declared profile `shape` samples x points."""
    name = "stub"

    def __init__(self, shape, declared="line"):
        self.shape, self.declared = shape, declared

    def energy(self, p, obs):
        return None

    def figures(self, p):
        return [{"kind": "profile", "panels": [{"y": self.declared}]}]

    def observables(self, p, obs):
        return {"line": np.ones(self.shape), "level": np.arange(self.shape[0], dtype=float)}


def test_series_refuses_a_profile_too_long_or_missing():
    stacked = {"t": np.arange(3.0)}
    assert series(_Stub((3, PROFILE_POINTS)), {}, stacked)["line"] == [1.0] * PROFILE_POINTS
    with pytest.raises(ValueError, match="at most 400 numbers per sample"):
        series(_Stub((3, PROFILE_POINTS + 1)), {}, stacked)
    with pytest.raises(ValueError, match="at most 400 numbers per sample"):
        series(_Stub((3,)), {}, stacked)  # a time series is not a profile
    with pytest.raises(ValueError, match="'missing', which is not one of its observables"):
        series(_Stub((3, 4), declared="missing"), {}, stacked)


def test_profile_figure_draws_each_grid_stored_profile_over_ghia(cavity_run, monkeypatch):
    """One figure for both sections (shared), two axes (u(y), v(x)): each grid's line is its
    stored series against the declared coordinates, Ghia's points and refsim's c_inf as
    declared, colours from light (n = 16) to dark (n = 32)."""
    from refsim_cases.grid_fluids._ghia import PROFILE, ghia
    from refsim_cases.grid_fluids.cavity import CONVERGED
    table = pd.read_csv(cavity_run / "results.csv", keep_default_na=False,
                        na_values=[""]).fillna({"engine_variant": ""})
    stored = load_series(cavity_run)
    definitions = Definitions.of_run(cavity_run)
    sections = [(definitions.of_row(rows.iloc[0]), rows)
                for _, rows in table.groupby(["case", "variant"], sort=False)]
    first, second = (build.declared_figures(sections, k) for k in (0, 1))
    assert second == [("p", 'Figure "centrelines at t = T = 0.5 s, Re = 100" (cavity / '
                            'default, cavity / n32) is drawn once, in section cavity / '
                            'default.')]
    (spec, rows, stem), = first
    assert stem == "shared-cavity_centrelines" and list(rows["figure_group"]) == [
        "n=16", "n=32"]
    saved = _captured(monkeypatch)
    assert plots.profile(rows, stored, row_key, spec, cavity_run / "p.png", "t") is not None
    (fig,) = saved
    g = ghia()
    for ax, name, coord, value, k in zip(fig.axes, ("u_centreline", "v_centreline"),
                                         ("u_y", "v_x"), ("u", "v"), (0, 17)):
        lines = {line.get_label(): line for line in ax.get_lines()}
        for group, colour in (("n=16", plots.PROFILE_COLOURS[0]),
                              ("n=32", plots.PROFILE_COLOURS[-1])):
            line = lines[f"{group} sl_linear [direct]"]
            row = rows[rows["figure_group"] == group].iloc[0]
            np.testing.assert_array_equal(line.get_xdata(), PROFILE)
            np.testing.assert_array_equal(line.get_ydata(), stored[row_key(row)][name])
            assert line.get_color() == colour
        data = lines["Ghia, Ghia & Shin (1982), 129^2"]
        np.testing.assert_array_equal(data.get_xdata(), g[coord])
        np.testing.assert_array_equal(data.get_ydata(), g[value])
        c_inf = lines["refsim c_inf (Richardson, n = 32-128)"]
        assert c_inf.get_linestyle() == "--"
        np.testing.assert_array_equal(c_inf.get_ydata(), CONVERGED[k:k + 17])


def test_report_places_the_shared_figure_once(cavity_run):
    """The shared figure under the first section declaring it, a line pointing to it under
    the other; no per-section copy."""
    md = (cavity_run / "report.md").read_text()
    images = re.findall(r"!\[([^]]*)\]\(([^)]+)\)", md)
    assert [title for title, path in images if "centrelines" in path] == ["cavity / default"]
    n32 = md[md.index("## cavity / n32"):]
    assert "is drawn once, in section cavity / default" in n32
    assert (cavity_run / "plots" / "shared-cavity_centrelines.png").stat().st_size > 2_000
    stored = json.loads((cavity_run / "cases.json").read_text())
    assert all(d["figures"][0]["shared"] == "cavity_centrelines" for d in stored)


def _front_rows():
    """Two cases' rows (an SPH and a FLIP dam break, say) with stored fronts."""
    rows = pd.DataFrame([
        {"case": "sph", "variant": "a", "engine": "refsim", "engine_variant": "",
         "integrator": "velocity_verlet", "dt": 1e-3, "status": "ok", "err_rms": 0.4,
         "time_shift": 0.1},
        {"case": "flip", "variant": "b", "engine": "refsim", "engine_variant": "direct",
         "integrator": "pic", "dt": 2e-3, "status": "ok", "err_rms": 0.3,
         "time_shift": -0.2},
        {"case": "flip", "variant": "b", "engine": "taichi", "engine_variant": "",
         "integrator": "pic", "dt": 2e-3, "status": "unsupported", "err_rms": np.nan,
         "time_shift": np.nan}])
    T = np.linspace(0.0, 3.0, 7)
    stored = {row_key(rows.iloc[0]): {"T": T.tolist(), "front": (1 + T ** 2).tolist()},
              row_key(rows.iloc[1]): {"T": T.tolist(), "front": (1 + 0.8 * T).tolist()}}
    return rows, stored, T


def test_shared_front_figure_draws_both_cases_side_by_side(tmp_path, monkeypatch):
    """A trace_over_data figure shared by two cases: one figure, a panel per case and engine
    (the case in its title), each line the stored front shifted by the row's fitted shift,
    the same axis ranges in both panels."""
    from refsim_cases._martin_moyce import front_figure
    spec, = front_figure()
    rows, stored, T = _front_rows()
    sections = [({"case": "sph", "variant": "a", "figures": [spec], "params": {}},
                 rows.iloc[:1]),
                ({"case": "flip", "variant": "b", "figures": [spec], "params": {}},
                 rows.iloc[1:])]
    (drawn_spec, drawn, stem), = build.declared_figures(sections, 0)
    assert build.declared_figures(sections, 1)[0][0] == "p"
    saved = _captured(monkeypatch)
    assert plots.trace_over_data(drawn, stored, row_key, drawn_spec, tmp_path / "f.png",
                                 "t") is not None
    (fig,) = saved
    assert [ax.get_title() for ax in fig.axes] == ["sph/a refsim", "flip/b refsim"]
    for ax, k in zip(fig.axes, (0, 1)):
        row = rows.iloc[k]
        line = next(x for x in ax.get_lines() if x.get_label().startswith(
            f"refsim{':direct' if k else ''} {row['integrator']} (shift"))
        np.testing.assert_array_equal(line.get_xdata(), T + row["time_shift"])
        np.testing.assert_array_equal(line.get_ydata(), stored[row_key(row)]["front"])
    assert fig.axes[0].get_xlim() == fig.axes[1].get_xlim()
    assert fig.axes[0].get_ylim() == fig.axes[1].get_ylim()


def test_both_dam_break_cases_declare_the_same_shared_front():
    from refsim.registry import get_case
    specs = [get_case(name).figures(get_case(name).variant_params(variant))
             for name in ("dam_break", "flip_dam_break")
             for variant in get_case(name).variants]
    assert len({s[0]["shared"] for s in specs}) == 1 and specs[0][0]["shared"]
