"""`refsim stress --case NAME`: the cases that declare a stability parameter, their theory,
and the stored limit rows (measured and theory columns for the report)."""
import argparse
import contextlib
import io
import math

import numpy as np
import pytest

from refsim.cli import stress as stress_cli
from refsim.stress import limits as stress
from refsim.registry import get_case, get_engine
from refsim.store.results import load_definitions_list, load_results
from refsim.stress.search import Criterion, find_limit, finite_time, theory
from refsim.stress.spec import Probe, declared_formulations
from refsim.integrators import get_integrator


def parse(*argv):
    parser = argparse.ArgumentParser()
    stress_cli.add_arguments(parser)
    return parser.parse_args(list(argv))


def test_kdk_cfl_limit_without_diffusion_is_leapfrogs_omega_dt_of_two():
    """Without delta-SPH the limit is omega_max dt = 2 with omega_max = c0 V max|G(k)|, so
    CFL * h V max|G| = 2: recomputed here from the lattice sum by brute force."""
    from refsim_cases.sph.hydrostatic_tank import kdk_cfl_limit
    from refsim.models.sph import wendland_gradient_factor
    h = 1.3
    n = np.arange(-4, 5, dtype=float)
    r = np.stack(np.meshgrid(n, n), -1).reshape(-1, 2)
    r = r[np.linalg.norm(r, axis=1) > 0]
    grad = wendland_gradient_factor(np.linalg.norm(r, axis=1), h)[:, None] * r
    k = np.linspace(0, np.pi, 121)
    waves = np.stack(np.meshgrid(k, k), -1).reshape(-1, 2)
    g_max = np.linalg.norm(np.sin(waves @ r.T) @ grad, axis=1).max()
    assert kdk_cfl_limit(h, 0.0) == pytest.approx(2.0 / (h * g_max), abs=2e-6)
    # the explicit density diffusion lowers it
    assert kdk_cfl_limit(h, 0.1) < kdk_cfl_limit(h, 0.0) - 0.1


def test_tank_declares_the_cfl_number_and_its_theory():
    tank = get_case("hydrostatic_tank")
    probe = Probe(tank)
    spec, p = probe.spec, probe.p
    assert spec.name.startswith("CFL number")
    assert spec.to_dt(1.0) == pytest.approx(p["smoothing"] * tank.spacing(p) /
                                            tank.sound_speed(p))
    limit, why = spec.theory(None, {"integrator": {"family": "kick-drift-kick (leapfrog)"}})
    assert 1.5 < limit < 1.7 and "von Neumann" in why
    assert math.isnan(spec.theory(None, {"integrator": {"family": "RK4"}})[0])


def test_pendulum_theory_only_in_generalized_coordinates():
    spec = Probe(get_case("pendulum")).spec
    se = get_integrator("symplectic_euler")
    generalized = {"formulation": "generalized coordinate (hinge angle)"}
    nested = {"bodies": [{"formulation": "1 hinge joint: generalized coordinate"}]}
    maximal = {"joints": {"formulation": "maximal coordinates, sequential impulses"}}
    assert declared_formulations(nested) == ["1 hinge joint: generalized coordinate"]
    assert spec.theory(se, generalized)[0] == 2.0 and spec.theory(se, nested)[0] == 2.0
    assert math.isnan(spec.theory(se, maximal)[0]) and math.isnan(spec.theory(se, {})[0])


def test_pendulum_generalized_limits_match_the_springs():
    """refsim's generalized pendulum at theta0 = 1e-3: symplectic Euler and RK4 land where the
    oscillator criterion predicts (finite_time), as on the spring."""
    probe, crit = Probe(get_case("pendulum")), Criterion(100)
    for name in ("symplectic_euler", "rk4"):
        stepper = get_integrator(name)
        y_ft, res = finite_time(stepper, theory(stepper), crit)
        found = find_limit(get_engine("refsim"), name, probe, crit, 1e-3, "generalized")
        assert abs(found.limit - y_ft) <= 2e-3 * max(1.0, y_ft), name


def test_refsim_backward_euler_pendulum_is_stable_at_every_y_searched():
    """Backward Euler on the small-amplitude pendulum is unconditionally stable: its Newton
    solve must not stall at large omega dt (it did at y = 29.7 with the explicit-Euler
    predictor, which put theta 880 amplitudes away)."""
    probe, crit = Probe(get_case("pendulum")), Criterion(100)
    found = find_limit(get_engine("refsim"), "implicit_euler", probe, crit, 1e-3, "generalized")
    assert found.limit == math.inf


def test_mujoco_discrete_on_the_hinge_is_held_to_symplectic_euler():
    """MuJoCo's discrete solves joint stiffness implicitly (backward Euler on a spring) but the
    pendulum's restoring force is gravity's torque, explicit: its theory there is the
    symplectic Euler limit 2, declared by the Sim for this scene."""
    pytest.importorskip("mujoco")
    eq, th, why, _, _ = stress.limit_theory(get_engine("mujoco"), "discrete",
                                            Probe(get_case("pendulum")), Criterion(100))
    assert (eq, th) == ("symplectic_euler", 2.0)
    eq, th, _, _, _ = stress.limit_theory(get_engine("mujoco"), "discrete",
                                          Probe(get_case("stiff_spring")), Criterion(100))
    assert (eq, th) == ("implicit_euler", math.inf)


@pytest.mark.slow
def test_tank_measured_limit_agrees_with_theory(tmp_path):
    """refsim's WCSPH tank (resolution 20): the quick search's limit within the declared
    resolution of the von Neumann limit, stored with measured and theory columns."""
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert stress_cli.main(parse("--case", "hydrostatic_tank", "--engine", "refsim",
                                 "--quick", "--out", str(tmp_path))) == 0
    (run,) = tmp_path.iterdir()
    (row,) = load_results(run).to_dict("records")
    assert row["case"] == "hydrostatic_tank" and row["variant"] == "stability_limit"
    assert (row["consistency"] == "consistent") and abs(row["measured"] - row["theory"]) <= row["tolerance"]
    (definition,) = load_definitions_list(run)
    assert {"measured", "theory"} <= set(definition["report_columns"])
    assert definition["units"] == "y = CFL number c0 dt / h"
    assert "von Neumann" in printed.getvalue()


def test_case_without_stability_declaration_is_refused(tmp_path):
    with pytest.raises(ValueError, match="^--case 'free_fall' declares no stability"):
        stress_cli.main(parse("--case", "free_fall", "--out", str(tmp_path)))
    with pytest.raises(ValueError, match="^--case must be one of"):
        stress_cli.main(parse("--case", "nope", "--out", str(tmp_path)))
    assert not any(tmp_path.iterdir())
