"""stiff_spring: the bound is the named method's exact discrete solution's error (plus
round-off), so a correct engine meets it and a wrong method, a wrong stiffness, a forgotten
mass or a velocity damping of 1e-4 per step exceeds it."""
import json

import numpy as np
import pytest

from refsim_adapters.planted_defects.checks import sweep, uncaught
from refsim_cases.particles.stiff_spring import CASE
from refsim.integrators import ExplicitRK, Tableau, get_integrator
from refsim.run.job import Job, run_job
from refsim.registry import get_case
from refsim.run.runner import expand

# Kutta's third-order method (Butcher 2016, sec. 233): an "rk4" one order short
KUTTA3 = Tableau(a=((0, 0, 0), (0.5, 0, 0), (-1, 2, 0)), b=(1 / 6, 2 / 3, 1 / 6),
                 c=(0, 0.5, 1), order=3)
IMPOSTORS = {"heun": lambda: get_integrator("heun"),
             "kutta3": lambda: ExplicitRK("rk4", KUTTA3),
             "explicit_euler": lambda: get_integrator("explicit_euler")}
# (named, impostor): an "rk4" one or two orders short, a "velocity_verlet" that is Euler
WRONG_METHODS = [("rk4", "heun"), ("rk4", "kutta3"), ("velocity_verlet", "explicit_euler")]


def named_bound(row, p, named):
    """The bound the row's case gives the NAMED method at the row's dt (its order and
    description, whatever ran)."""
    case, method = get_case(row["case"]), get_integrator(named)
    settings = {**json.loads(row["settings"]), "integrator": method.describe()}
    return case.tolerance(p, named, method.order, row["dt"], row["engine_variant"],
                          settings)[0]


def impostor_row(monkeypatch, case, variant, named, impostor, dt, engine_variant=""):
    """refsim's engine asked for `named` running `impostor` instead (the steppers it builds)."""
    import refsim_adapters.refsim_engine.groups.particles as refsim_engine  # builds the steppers
    real = refsim_engine.get_integrator
    monkeypatch.setattr(refsim_engine, "get_integrator",
                        lambda spec: IMPOSTORS[impostor]() if spec == named else real(spec))
    row = run_job(Job(case.name, variant, "refsim", engine_variant, named, dt), repeats=0)
    monkeypatch.setattr(refsim_engine, "get_integrator", real)
    return row


def impostor_uncaught(monkeypatch, case, variant, named, impostor, engine_variant="",
                      skipped=lambda status: status == "diverged"):
    """checks.uncaught for `impostor_row` at every dt of the variant's sweep, against the bound
    the case gives `named` (named_bound), above the case's error floor: a row whose status is
    `skipped` is not judged (caught by the run itself), any other status but ok fails."""
    p = case.variant_params(variant)

    def judged(dt):
        row = impostor_row(monkeypatch, case, variant, named, impostor, dt, engine_variant)
        if skipped(row["status"]):
            return None
        assert row["status"] == "ok", row["reason"]
        return row["err_max"], named_bound(row, p, named)
    return uncaught(sweep(case, p), judged, case.error_floor(p))


def scene_defect_row(monkeypatch, case, variant, integrator, dt, change, engine_variant=""):
    """refsim's engine on a defective scene (`change(p)`: the parameters it is built from),
    judged against the case's own reference and bound."""
    build = type(case).scene
    monkeypatch.setattr(case, "scene", lambda p: build(case, change(dict(p))))
    row = run_job(Job(case.name, variant, "refsim", engine_variant, integrator, dt),
                  repeats=0)
    monkeypatch.undo()
    return row


def finest_scene_defect(monkeypatch, case, variant, integrator, change, engine_variant=""):
    """(row, bound): `scene_defect_row` at the variant's finest timed dt and the bound the case
    gives `integrator` there (named_bound)."""
    p = case.variant_params(variant)
    row = scene_defect_row(monkeypatch, case, variant, integrator, min(case.dts(p)), change,
                           engine_variant)
    return row, named_bound(row, p, integrator)


@pytest.mark.parametrize("variant", ["default", "critical"])
@pytest.mark.parametrize("integrator", ["explicit_euler", "symplectic_euler", "heun", "rk4",
                                        "velocity_verlet", "stormer_verlet", "leapfrog",
                                        "implicit_euler", "dopri5_adaptive"])
def test_refsim_rows_within_their_bound_and_near_it(variant, integrator):
    """A correct engine is within the bound; where truncation dominates (err above 1e3 x the
    round-off) the bound IS the error, to its round-off term (fixed steps), within 3x
    (adaptive: the controller steps below its limit h(t))."""
    p = CASE.variant_params(variant)
    for dt in CASE.dts(p):
        row = run_job(Job(CASE.name, variant, "refsim", "", integrator, dt), repeats=0)
        if row["status"] != "ok":
            continue
        bound = named_bound(row, p, integrator)
        if bound >= CASE.motion_scale(p):
            continue  # unresolved
        assert row["err_max"] <= bound, (dt, row["err_max"], bound)
        if row["err_max"] > 1e3 * CASE.error_floor(p):
            assert bound / row["err_max"] < (3.0 if "adaptive" in integrator else 1.01)


@pytest.mark.parametrize("named, impostor", WRONG_METHODS)
@pytest.mark.parametrize("variant", ["default", "underdamped"])
def test_wrong_method_exceeds_the_named_methods_bound(monkeypatch, variant, named, impostor):
    """At every dt of the sweep where it errs above the floor (or diverges)."""
    assert not impostor_uncaught(monkeypatch, CASE, variant, named, impostor)


@pytest.mark.parametrize("defect, change", [
    ("stiffness +1 %", lambda p: {**p, "stiffness": 1.01 * p["stiffness"]}),
    ("mass forgotten (taken as 1 kg)", lambda p: {**p, "mass": 1.0,
                                                 "zeta": p["zeta"] * np.sqrt(p["mass"])}),
])
@pytest.mark.parametrize("integrator", ["rk4", "velocity_verlet", "dopri5_adaptive"])
def test_physical_defects_exceed_the_bound_at_the_finest_dt(monkeypatch, defect, change,
                                                            integrator):
    row, bound = finest_scene_defect(monkeypatch, CASE, "underdamped", integrator, change)
    assert row["status"] == "ok" and row["err_max"] > 10 * bound, defect


@pytest.mark.parametrize("integrator", ["rk4", "velocity_verlet", "dopri5"])
def test_velocity_damping_of_1e_4_per_step_exceeds_the_bound(monkeypatch, integrator):
    """A damping of 1e-4 of v per step is a dashpot c = 1e-4 m / dt (to O(1e-8))."""
    p = CASE.variant_params("default")
    dt = min(CASE.dts(p))
    row = scene_defect_row(monkeypatch, CASE, "default", integrator, dt, lambda q: {
        **q, "zeta": 1e-4 * q["mass"] / dt / (2 * np.sqrt(q["stiffness"] * q["mass"]))})
    assert row["status"] == "ok" and row["err_max"] > 10 * named_bound(row, p, integrator)


def test_no_unit_mass():
    p = CASE.variant_params("default")
    assert p["mass"] != 1.0 and CASE.omega(p) == pytest.approx(100.0)


@pytest.mark.slow
def test_every_default_matrix_row_within_its_bound():
    """The whole default matrix (345 rows, ~1 min): zero rows above their bound; bound/error
    median and 90th percentile as measured when written (1.0 and 1.0; adaptive <= 2.4)."""
    ratios = []
    for job in expand(cases=[CASE.name], engines=["refsim"]):
        row = run_job(job, repeats=0)
        p = CASE.variant_params(job.variant)
        if row["status"] != "ok":
            continue
        bound = named_bound(row, p, job.integrator)
        if bound < CASE.motion_scale(p):
            assert row["err_max"] <= bound, job.label
            ratios.append(bound / row["err_max"])
    assert np.median(ratios) <= 5 and np.percentile(ratios, 90) <= 30
