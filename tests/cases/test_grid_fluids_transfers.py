"""The transfers case (cases/grid_fluids/transfers.py): its scenes, its theory-based bounds,
and the in-house particle-fluid step run on its scenes against them (the engine group's
wiring aside: ParticleFluid.from_scene is what a group builds)."""
from __future__ import annotations

import numpy as np
import pytest

from refsim.models.grid_fluid.particle_fluid import ParticleFluid
from refsim.models.grid_fluid.transfer import (KERNELS, SCHEMES, TRANSFER_SPECS,
                                               parse_transfer)
from refsim_cases.grid_fluids.transfers import CASE

SPECS = [s for s in TRANSFER_SPECS if not s.startswith("blend")] + \
    [f"blend_{k}:0.95" for k in KERNELS]


def run(variant, spec, method="direct"):
    """(observed, error, bound) of the in-house step on the variant's scene."""
    p = CASE.variant_params(variant)
    sim = ParticleFluid.from_scene(CASE.scene(p), parse_transfer(spec), method)
    stride = CASE.steps(p) // CASE.samples
    obs = {"x": [sim.observe()["x"]], "v": [sim.observe()["v"]]}
    for _ in range(CASE.samples):
        for _ in range(stride):
            sim.step(p["dt"])
        obs["x"].append(sim.observe()["x"])
        obs["v"].append(sim.observe()["v"])
    t = np.arange(CASE.samples + 1) * stride * p["dt"]
    stacked = {k: np.array(v) for k, v in obs.items()}
    energy = CASE.energy(p, stacked)
    assert abs(energy[0] / CASE.energy_scale(p) - 1) < 0.05  # seeded M vs rho area: ~1 %
    if p["flow"] == "rotation":  # the energy is the kinetic energy the error compares
        np.testing.assert_allclose(energy / energy[0], CASE.observables(p, stacked)[
            "ke_ratio"], rtol=1e-14)  # same sums in another order
    observed = CASE.observables(p, stacked)
    err = CASE.error(p, observed, CASE.reference(p, t))
    return p, observed, err, CASE.tolerance(p, spec, 1, p["dt"])[0]


@pytest.mark.parametrize("spec", SPECS)
def test_rotation_within_each_schemes_theory(spec):
    p, observed, err, bound = run("rotation", spec)
    assert err[0] == 0.0 and np.max(err) <= bound
    scheme = parse_transfer(spec)
    if scheme.name in ("apic", "flip"):  # the splitting, from below too (measured 0.95-0.98)
        assert err[-1] > 0.9 * CASE.splitting_loss(p)[0]
        spin_loss = 1 - observed["spin_ratio"][-1]
        assert abs(spin_loss / CASE.splitting_loss(p)[1] - 1) < 0.1  # L x cos^(N-1)(omega dt)
    else:  # PIC's smoothing is there (measured 0.88 (PIC), 0.93-0.94 (blend) of the bound)
        assert err[-1] > 0.8 * bound


def test_particle_advection_keeps_apic_angular_momentum():
    """x += dt v_p: APIC's particles keep L up to the projection's torque and the affine part
    the observation leaves out (~h^2 / (2 R_g^2) = 1 % of L, changing as omega does)."""
    p, observed, err, bound = run("rotation_particle_advection", "apic_quadratic_bspline")
    assert np.max(err) <= bound
    assert abs(1 - observed["spin_ratio"][-1]) < 1e-3  # rk2_grid loses 8e-3 (cos^N)


@pytest.mark.parametrize("spec", SPECS)
def test_still_tank_spurious_current_within_the_solve(spec):
    p, observed, err, bound = run("still_tank", spec)
    assert np.max(err) <= bound  # measured 5e-16..9e-16 m/s (bound 5.8e-9 m/s)
    assert np.max(err) <= 1e-6 * bound  # the direct solve: round-off, far below rtol's term


@pytest.mark.parametrize("method", ["cg", "pyamg"])
def test_still_tank_with_iterative_solves(method):
    p, observed, err, bound = run("still_tank", "flip_quadratic_bspline", method)
    assert np.max(err) <= bound  # measured 5.8e-13 (cg), 2.1e-12 (pyamg) m/s


def test_apic_without_the_initial_gradient_pays_one_pic_transfer():
    """APIC's affine vectors start at 0 without the scene's velocity_gradient: its first P2G
    is then PIC's and loses the smoothing f once (measured 0.93 f) on top of the splitting."""
    p = CASE.variant_params("rotation")
    scene = CASE.scene(p)
    scene = scene.__class__(parts=scene.parts, gravity=scene.gravity, dim=2,
                            meta={"solve": "particles"})
    sim = ParticleFluid.from_scene(scene, parse_transfer("apic_quadratic_bspline"))
    assert np.all(sim.c == 0.0)
    ke0 = 0.5 * np.sum(sim.m * np.sum(sim.vel ** 2, axis=1))
    for _ in range(CASE.steps(p)):
        sim.step(p["dt"])
    extra = 1 - 0.5 * np.sum(sim.m * np.sum(sim.vel ** 2, axis=1)) / ke0 - \
        CASE.splitting_loss(p)[0]
    assert 0.8 < extra / CASE.smoothing_fraction(p, "quadratic_bspline") < 1.0


def test_bounds_and_parameters():
    p = CASE.variant_params("rotation")
    f_b = CASE.smoothing_fraction(p, "quadratic_bspline")
    # B-spline: f = h^2 / R_g^2 with R_g^2 -> R^2 / 2 for the seeded disk (1 % here)
    assert abs(f_b / ((1 / 32) ** 2 / (0.3 ** 2 / 2)) - 1) < 0.02
    assert CASE.smoothing_fraction(p, "bilinear") < f_b  # D <= h^2 / 4 under the hat
    pic, flip = (CASE.tolerance(p, s, 1, 0.01)[0] for s in ("pic_bilinear", "flip_bilinear"))
    assert flip < pic
    assert set(SCHEMES) == {parse_transfer(s).name for s in SPECS}
    for bad in ({"t_end": 0.405}, {"flow": "still_tank", "depth": 0.51}):
        with pytest.raises(ValueError):
            CASE.validate(bad)
    scene = CASE.scene(p)
    assert scene.part_kinds() == {"fluid_grids", "particles"} and scene.dim == 2
