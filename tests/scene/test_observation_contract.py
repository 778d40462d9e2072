"""The observation contract: the in-house engine's observe() meets it on every case, and
check_observation names what a broken observation lacks or gets wrong, for every part."""
import numpy as np
import pytest

from refsim.observation import OBSERVABLES, check_observation, contract_markdown, expected
from refsim.registry import case_names, get_case, get_engine
from refsim.scene import (PART_KINDS, Body, ContactModel, FluidBlock, Grid, Joint, Material,
                          RigidBodies, Scene, SpringNetwork, TriangleMesh, Wall)
from refsim.scene import Joints, Particles, Walls

ENGINE = get_engine("refsim")


def _builds():
    """Every quick variant the in-house engine runs (it refuses rolling_disc with a reason:
    frictional rigid contact is no slides' model; the engines' own tests check that case)."""
    for name in case_names():
        case = get_case(name)
        for variant in case.quick_variants:
            scene = case.scene(case.variant_params(variant))
            if ENGINE.supports(scene) is not None:
                continue
            for formulation in ENGINE.formulations(scene):
                yield name, variant, formulation


@pytest.mark.parametrize("name,variant,formulation", list(_builds()))
def test_the_inhouse_engine_meets_the_contract_on_every_case(name, variant, formulation):
    case = get_case(name)
    p = case.variant_params(variant)
    scene = case.scene(p)
    integrator = "velocity_verlet" if scene.part(FluidBlock) is not None else "symplectic_euler"
    if ENGINE.supports(scene, integrator) is not None:  # a first-order scene: its own steppers
        integrator = next(i for i in ENGINE.offered_integrators(scene)
                          if ENGINE.supports(scene, i) is None)
    sim = ENGINE.build(scene, case.reference_dt(p), integrator, formulation)
    assert check_observation(sim.observe(), scene) == []
    sim.step(1)
    assert check_observation(sim.observe(), scene) == []


BALLS = (Body(1.0, (0.0, 0.0, 1.0), radius=0.1, inertia=0.004),
         Body(1.0, (1.0, 0.0, 1.0), radius=0.1, inertia=0.004))
PENDULUM = Scene(parts=(Particles.of(BALLS[:1]), Joints.of((Joint(0, (0.0, 0.0, 2.0), 1.0),))), gravity=(0.0, 0.0, -9.81))
SPHERES = Scene(parts=(Particles.of(BALLS), Walls.of((Wall((0, 0, 0), (0, 0, 1)),))), contact=ContactModel())
TANK = Scene(parts=(FluidBlock((0.0, 0.0), (0.5, 1.0), 0.1, 2.0, 1.5),), dim=2)
RIGID = Scene(parts=(RigidBodies(mass=[1.0, 2.0], inertia=[np.eye(3)] * 2,
                                position=np.zeros((2, 3)), orientation=[[1.0, 0, 0, 0]] * 2),))
SQUARE = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
CLOTH = Scene(parts=(SpringNetwork(SQUARE, 0.1, [[0, 1], [1, 2], [2, 3], [3, 0]], 10.0), SpringNetwork(SQUARE[:3] + 2.0, 0.1, [[0, 1], [1, 2]], 10.0)))
PLATE = Scene(parts=(TriangleMesh(SQUARE, [[0, 1, 2], [0, 2, 3]], Material(1e6, 0.3, 1e3)),))
HEAT = Scene(parts=(Grid((6, 5), 0.1, "diffusion", {"T": np.ones((6, 5)),
                                                    "source": np.zeros((6, 5))}),))


def _obs(scene, **overrides):
    """A conforming observation of `scene`: every required name at its expected shape."""
    out = {name: np.zeros(shape) for name, (shape, required) in expected(scene).items()
           if required}
    out.update(overrides)
    return {k: v for k, v in out.items() if v is not None}


CONFORMING = {  # scene, the required names beside "t"
    "particles": (SPHERES, {"x": (2, 3), "v": (2, 3)}),
    "joints": (PENDULUM, {"x": (1, 3), "v": (1, 3)}),
    "fluid": (TANK, {"x": (50, 2), "v": (50, 2), "rho": (50,), "mass": (50,)}),
    "rigid": (RIGID, {"x": (2, 3), "v": (2, 3), "q": (2, 4), "w": (2, 3)}),
    "networks": (CLOTH, {"x": (7, 3), "v": (7, 3)}),
    "meshes": (PLATE, {"x": (4, 3), "v": (4, 3)}),
    "grids": (HEAT, {"grid.T": (6, 5), "grid.source": (6, 5)}),
}


@pytest.mark.parametrize("kind", sorted(CONFORMING))
def test_the_required_names_and_shapes_per_part(kind):
    scene, names = CONFORMING[kind]
    required = {n: s for n, (s, req) in expected(scene).items() if req}
    assert required == {"t": (), **names}
    assert check_observation(_obs(scene), scene) == []


@pytest.mark.parametrize("kind", sorted(CONFORMING))
def test_a_missing_required_name_is_reported(kind):
    scene, names = CONFORMING[kind]
    for name in ["t", *names]:
        problems = check_observation(_obs(scene, **{name: None}), scene)
        assert len(problems) == 1 and f"missing {name!r}" in problems[0]


@pytest.mark.parametrize("kind", sorted(CONFORMING))
def test_a_wrong_shape_is_reported(kind):
    scene, names = CONFORMING[kind]
    for name, shape in names.items():
        wrong = np.zeros((shape[0] + 1,) + shape[1:])
        problems = check_observation(_obs(scene, **{name: wrong}), scene)
        assert problems == [f"{name!r} has shape {wrong.shape}, expected {shape}"]


def test_optional_names_are_checked_when_reported_and_extras_pass():
    assert check_observation(_obs(SPHERES, w=np.zeros((2, 3)), wall_impulse=np.zeros(3),
                                  contacts_seen=np.arange(5)), SPHERES) == []
    assert check_observation(_obs(SPHERES, w=np.zeros((2, 2))), SPHERES) == [
        "'w' has shape (2, 2), expected (2, 3)"]
    assert check_observation(_obs(SPHERES, wall_impulse=np.zeros(2)), SPHERES) == [
        "'wall_impulse' has shape (2,), expected (3,)"]
    assert check_observation(_obs(PENDULUM, constraint=np.zeros(1)), PENDULUM) == []
    assert check_observation(_obs(PENDULUM, constraint=np.zeros((1, 3))), PENDULUM) == [
        "'constraint' has shape (1, 3), expected (1,)"]


def test_x_belongs_to_the_scenes_one_moving_kind():
    """A network's "x" holds every node of every network; a fluid's "x" is planar; a grid
    scene has no "x" at all."""
    assert expected(CLOTH)["x"] == ((7, 3), True)
    assert expected(TANK)["x"] == ((TANK.part(FluidBlock).particle_count, 2), True)
    assert "x" not in expected(HEAT)


def test_the_table_documents_every_name_once_per_part():
    keys = [(o.name, o.part) for o in OBSERVABLES]
    assert len(keys) == len(set(keys))
    assert {o.part for o in OBSERVABLES} <= set(PART_KINDS) | {"scene"}
    assert all(o.units and o.meaning and o.shape for o in OBSERVABLES)
    table = contract_markdown()
    assert table.count("\n") == len(OBSERVABLES) + 1
    assert all(f"`{o.name}`" in table for o in OBSERVABLES)
