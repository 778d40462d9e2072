"""free_fall: the bound is the named method's exact discrete solution's error (g carried by a
constant coordinate) plus round-off: a correct engine meets it, and a wrong method, gravity
+0.1 %, a forgotten mass or a velocity damping of 1e-4 per step exceeds it."""
import pytest
from test_stiff_spring import finest_scene_defect, impostor_uncaught, named_bound, \
    scene_defect_row

from refsim_adapters.planted_defects.checks import sweep
from refsim_cases.particles.free_fall import CASE
from refsim.run.job import Job, run_job
from refsim.run.runner import expand


@pytest.mark.parametrize("variant", ["default", "drag"])
@pytest.mark.parametrize("integrator", ["explicit_euler", "symplectic_euler",
                                        "symplectic_euler_dk", "midpoint", "rk4",
                                        "velocity_verlet", "stormer_verlet", "implicit_euler",
                                        "baraff_witkin", "dopri5_adaptive"])
def test_refsim_rows_within_their_bound_and_at_it_above_the_floor(variant, integrator):
    """Within the bound at every dt of the sweep; above the error floor (truncation) the bound
    is the error itself, to 1 % (the round-off term); adaptive: within 3x (its controller
    steps below the limit h(t) the bound assumes)."""
    p = CASE.variant_params(variant)
    for dt in sweep(CASE, p):
        row = run_job(Job(CASE.name, variant, "refsim", "", integrator, dt), repeats=0)
        assert row["status"] == "ok", row["reason"]
        bound = named_bound(row, p, integrator)
        assert row["err_max"] <= bound, (dt, row["err_max"], bound)
        if row["err_max"] > CASE.error_floor(p):
            assert bound / row["err_max"] < (3.0 if "adaptive" in integrator else 1.01), \
                (dt, row["err_max"], bound)


def test_euler_bound_is_g_t_dt_over_2_without_drag():
    """The discrete solution gives the textbook result: explicit Euler's height after k steps
    errs k dt^2 g / 2 = g t dt / 2 (the slides)."""
    p, dt = CASE.variant_params("default"), 1e-3
    bound, why = CASE.tolerance(p, "explicit_euler", 1, dt)
    expected = p["g"] * p["duration"] * dt / 2
    assert expected <= bound <= expected + 1e-10 and "exact discrete solution" in why


@pytest.mark.parametrize("named, impostor, variants", [
    ("rk4", "heun", ["drag"]),  # Heun is exact without drag: nothing to catch there
    ("rk4", "kutta3", ["drag"]),
    ("velocity_verlet", "explicit_euler", ["default", "drag"])])
def test_wrong_method_exceeds_the_named_methods_bound(monkeypatch, named, impostor, variants):
    """At every dt of the sweep where it errs above the floor."""
    for variant in variants:
        assert not impostor_uncaught(monkeypatch, CASE, variant, named, impostor,
                                     skipped=lambda status: False), variant


@pytest.mark.parametrize("defect, change", [
    ("gravity +0.1 %", lambda p: {**p, "g": 1.001 * p["g"]}),
    ("gravity force m g not divided by m", lambda p: {**p, "g": p["mass"] * p["g"]}),
    # an engine applying a = -b v instead of -(b/m) v: the scene with b m in place of b
    ("drag force not divided by m", lambda p: {**p, "drag": p["drag"] * p["mass"]}),
])
@pytest.mark.parametrize("integrator", ["explicit_euler", "rk4", "velocity_verlet",
                                        "dopri5_adaptive"])
def test_physical_defects_exceed_the_bound_at_the_finest_dt(monkeypatch, defect, change,
                                                            integrator):
    row, bound = finest_scene_defect(monkeypatch, CASE, "drag", integrator, change)
    assert row["status"] == "ok" and row["err_max"] > 2 * bound, defect


@pytest.mark.parametrize("integrator", ["explicit_euler", "rk4", "velocity_verlet"])
def test_velocity_damping_of_1e_4_per_step_exceeds_the_bound(monkeypatch, integrator):
    """A damping of 1e-4 of v per step is a linear drag b = 1e-4 m / dt (to O(1e-8))."""
    p = CASE.variant_params("default")
    dt = min(CASE.dts(p))
    row = scene_defect_row(monkeypatch, CASE, "default", integrator, dt,
                           lambda q: {**q, "drag": 1e-4 * q["mass"] / dt})
    assert row["status"] == "ok" and row["err_max"] > 10 * named_bound(row, p, integrator)


def test_no_unit_mass():
    assert CASE.variant_params("default")["mass"] != 1.0
    p = CASE.variant_params("drag")
    assert p["mass"] / p["drag"] == pytest.approx(2.0)  # tau, as the order_dts assume


@pytest.mark.slow
def test_every_default_matrix_row_within_its_bound():
    """The whole default matrix (162 rows, ~15 s): zero rows above their bound; above the error
    floor the bound is the error (bound/error max 1.01; adaptive 1.9). Below it the bound is
    the linear worst-case round-off n eps S and the error the actual round-off, 18..500x
    less."""
    for job in expand(cases=[CASE.name], engines=["refsim"]):
        row = run_job(job, repeats=0)
        p = CASE.variant_params(job.variant)
        bound = named_bound(row, p, job.integrator)
        assert row["status"] == "ok" and row["err_max"] <= bound, job.label
        if row["err_max"] > CASE.error_floor(p):
            assert bound / row["err_max"] < (3.0 if "adaptive" in job.integrator else 1.01), \
                job.label
