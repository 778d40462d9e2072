"""The in-house engine's grid-fluid group: what it offers and refuses, its settings' scheme
equal to the method refsim defines, a step equal to FluidSolver's, and the other engines'
refusals naming the part kind."""
import numpy as np
import pytest

from refsim.integrators import method_info
from refsim.models.grid_fluid.solver import FluidSolver
from refsim.registry import get_engine
from refsim.scene import FluidGrid, Particles, Scene

ENGINE = get_engine("refsim")


def _scene(meta=None, dim=2, n=8):
    rng = np.random.default_rng(9)
    u, v = rng.standard_normal((n + 1, n)), rng.standard_normal((n, n + 1))
    u[[0, -1]] = 0.0
    v[:, [0, -1]] = 0.0
    part = FluidGrid(n, n, 1.0 / n, u, v, nu=0.01, lid=1.0)
    return Scene(parts=(part,), dim=dim, meta=meta or {})


def test_offers_the_schemes_and_the_projection_solvers():
    scene = _scene()
    assert ENGINE.supports(scene) is None
    assert ENGINE.formulations(scene) == ("direct", "cg", "pyamg", "multigrid")
    assert "multigrid" not in ENGINE.formulations(_scene(n=9))
    assert ENGINE.supports(scene, "sl_cubic:rk3") is None
    assert "backtrace must be one of" in ENGINE.supports(scene, "sl_linear:rk4")
    assert "meta asks solve = projection" in ENGINE.supports(scene, "steady")
    projection = _scene({"solve": "projection"})
    assert ENGINE.supports(projection, "steady") is None
    assert "integrator 'steady' only" in ENGINE.supports(projection, "sl_linear")
    assert "2D MAC grids" in ENGINE.supports(_scene(dim=3))


@pytest.mark.parametrize("spec", ["sl_linear", "sl_cubic:euler", "sl_cubic_clamped:rk3"])
def test_a_step_is_fluid_solvers_step_and_settings_name_the_method(spec):
    scene = _scene()
    sim = ENGINE.build(scene, 0.02, spec, "direct")
    sim.step(3)
    solver = FluidSolver(scene.part(FluidGrid), spec, "direct")
    for _ in range(3):
        solver.step(0.02)
    obs = sim.observe()
    # the same operations in the same order: bit for bit
    assert np.array_equal(obs["grid.u"], solver.u) and np.array_equal(obs["grid.v"], solver.v)
    declared = sim.settings()["integrator"]
    assert {k: declared[k] for k in method_info(spec)} == method_info(spec)
    assert obs["residual"] <= scene.part(FluidGrid).rtol


def test_steady_projects_the_initial_field_every_step():
    scene = _scene({"solve": "projection"})
    sim = ENGINE.build(scene, 1.0, "steady", "cg")
    sim.step(1)
    first = sim.observe()
    sim.step(1)
    assert np.array_equal(sim.observe()["grid.u"], first["grid.u"])
    assert first["divergence"] < 1e-8 and sim.settings()["integrator"]["order"] == 0


def test_a_scene_with_particles_is_refused_with_the_reason():
    from refsim.scene import Body
    grid = _scene().part(FluidGrid)
    scene = Scene(parts=(grid, Particles.of([Body(1.0, (0.5, 0.5, 0.0))])),
                  dim=2)
    # (the engine gives such a scene to the particle-fluid group, which sorts first; this
    # group, asked directly, names the part it does not run)
    from refsim_adapters.refsim_engine.groups.grid_fluids import supports
    assert "a fluid grid alone, got also particles" in supports(ENGINE, scene, None)


@pytest.mark.parametrize("name", ["mujoco", "pybullet", "pymunk"])  # taichi runs it
def test_other_engines_refuse_the_part_kind_with_their_reason(name):
    reason = get_engine(name).supports(_scene())
    assert reason is not None and "grid" in reason and "fluid" in reason
