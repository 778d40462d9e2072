"""refsim's lennard_jones group: claims particles + LennardJones scenes, refuses mismatched ones
with a reason, steps with the four MD integrators, and its settings name the pair search."""
import json

import numpy as np
import pytest

from refsim_adapters.refsim_engine.engine import RefsimEngine
from refsim_cases.lennard_jones.lj_dimer import CASE as DIMER
from refsim_cases.lennard_jones.lj_gas import CASE as GAS
from refsim import registry
from refsim.scene import Particles, Scene
from refsim.scene.lennard_jones import LennardJones
from refsim.testing import accuracy

EPS = np.finfo(float).eps


@pytest.fixture(scope="module", autouse=True)
def registered():
    for name in ("lj_dimer", "lj_gas"):
        if name not in registry.names("case"):
            registry.register("case", name, f"refsim_cases.lennard_jones.{name}:CASE")


def _two_atoms(dim=3, box=None, z=0.0):
    x = np.array([[0.0, 0.0, 0.0], [1.2, 0.0, z]])
    part = LennardJones(cutoff=2.5 if box else np.inf, box=box)
    return Scene(parts=(Particles(mass=np.ones(2), position=x), part), dim=dim)


def test_group_claims_and_offers_the_md_integrators():
    engine = RefsimEngine()
    scene = DIMER.scene(DIMER.variant_params("small"))
    assert engine.group_for(scene).name == "lennard_jones"
    assert engine.offered_integrators(scene) == ("velocity_verlet", "symplectic_euler", "rk4",
                                                 "explicit_euler")
    assert engine.supports(scene, "implicit_euler") is not None


def test_group_refuses_a_box_of_the_wrong_dimension_and_a_2d_scene_off_its_plane():
    engine = RefsimEngine()
    assert "box has 3 lengths" in engine.supports(_two_atoms(2, (6.0, 6.0, 6.0)))
    assert "plane z = 0" in engine.supports(_two_atoms(2, z=0.1))
    assert engine.supports(_two_atoms(2, (6.0, 6.0))) is None


@pytest.mark.parametrize("integrator", ["velocity_verlet", "symplectic_euler", "rk4"])
def test_dimer_within_tolerance(integrator):
    p = DIMER.variant_params("small")
    row = accuracy("lj_dimer", "small", "refsim", integrator, DIMER.reference_dt(p))
    assert row["status"] == "ok" and (row["consistency"] == "consistent"), (row["err_max"], row["tolerance"])
    settings = json.loads(row["settings"])
    assert settings["pair_search"].startswith("all pairs") and settings["cutoff"] == "inf"


def test_gas_settings_name_the_periodic_cell_list():
    row = accuracy("lj_gas", "default", "refsim", "velocity_verlet", 5e-3, particles=100.0)
    settings = json.loads(row["settings"])
    assert row["status"] == "ok" and "cell list" in settings["pair_search"]
    assert settings["stages"][0] == "lennard_jones:cell_list_periodic" and settings["dim"] == 2


def test_explicit_euler_pumps_energy_into_the_dimer():
    """Explicit Euler multiplies a harmonic oscillation's energy by 1 + (w dt)^2 per step: after
    n steps E / E0 >= (1 + (w0 dt)^2)^n, w0 the smallest curvature on the orbit (the
    oscillation is nearly harmonic at A = 0.01 sigma)."""
    p = DIMER.variant_params("small")
    dt = DIMER.reference_dt(p)
    row = accuracy("lj_dimer", "small", "refsim", "explicit_euler", dt)
    growth = (1 + (DIMER.omega0(p) * dt) ** 2) ** row["steps"] - 1
    assert row["status"] == "ok" and row["energy_drift"] >= 0.9 * growth  # 10 %: anharmonic
