"""refsim_adapters.common: the shared scene refusals, hinge translation, contact data and SPH
lattices, and that every adapter gives the shared reasons."""
from __future__ import annotations

import math

import numpy as np
import pytest

from refsim_adapters.common import checks
from refsim_adapters.common.contacts import per_shape_coefficients
from refsim_adapters.common.hinges import HingeFrames, rod_length_errors, rod_start_refusal
from refsim_adapters.common.sph_lattice import (WALL_LAYERS, fluid_particles, hydrostatic_densities,
                                         plane_gravity, wall_particles)
from refsim.models.sph import tait_pressure
from refsim.registry import get_engine
from refsim.scene import Body, ContactModel, FluidBlock, Joint, Scene, Spring, Wall
from refsim.scene import Joints, Particles, Springs, Walls

G = (0.0, 0.0, -9.81)
ROD = Joint(body=0, anchor=(0.0, 0.0, 0.0), length=1.0)  # hinge axis y


def sphere(z, radius=0.1, inertia=0.004):
    return Body(mass=1.0, position=(0.0, 0.0, z), radius=radius, inertia=inertia)


def bob(position=(1.0, 0.0, 0.0), velocity=(0.0, 0.0, 0.0)):
    return Body(mass=1.0, position=position, velocity=velocity)


def spheres(second=None, friction=0.0, walls=(), **scene):
    bodies = (sphere(1.0), second or sphere(2.0))
    return Scene(parts=(Particles.of(bodies), Walls.of(walls)),
                 contact=ContactModel(friction=friction), **scene)


# -- checks: None when the scene passes, else "<who>: <what><why>" --------------------------------
def test_walls_without_contact_refused_with_who_and_why():
    floor = Wall(point=(0, 0, 0), normal=(0, 0, 1))
    bare = Scene(parts=(Particles.of((sphere(1.0),)), Walls.of((floor,))))
    assert checks.walls_without_contact(bare, "x adapter", " for e") == \
        "x adapter: walls need a contact model (scene.contact) for e"
    assert checks.walls_without_contact(spheres(walls=(floor,)), "x adapter") is None
    assert checks.walls_without_contact(Scene(parts=(Particles.of((sphere(1.0),)),)), "x adapter") is None


def test_non_sphere_bodies_names_the_first_point_mass():
    point = spheres(second=sphere(2.0, radius=0.0, inertia=0.0))
    assert checks.non_sphere_bodies(point, "x") == \
        "x: contacts need every body to be a sphere of radius > 0 (body 1 has radius 0)"
    assert checks.non_sphere_bodies(spheres(), "x") is None


def test_spheres_without_inertia_always_or_only_under_friction():
    spinless = sphere(2.0, inertia=0.0)
    assert checks.spheres_without_inertia(spheres(second=spinless), "x", why="; w") == \
        "x: contacts need every sphere's moment of inertia > 0 (body 1 has 0); w"
    assert checks.spheres_without_inertia(spheres(second=spinless), "x",
                                          friction_only=True) is None
    assert checks.spheres_without_inertia(spheres(second=spinless, friction=0.3), "x",
                                          friction_only=True) == \
        "x: friction needs every sphere's moment of inertia > 0 (body 1 has 0)"
    assert checks.spheres_without_inertia(spheres(friction=0.3), "x") is None


def test_rods_per_body_refuses_two_rods_and_with_every_body_a_free_body():
    two_rods = Scene(parts=(Particles.of((bob(),)), Joints.of((ROD, ROD))), gravity=G)
    free_too = Scene(parts=(Particles.of((bob(), bob((3.0, 0.0, 0.0)))), Joints.of((ROD,))), gravity=G)
    assert checks.rods_per_body(two_rods, "x", why=" (loop)") == "x: one rod per body (loop)"
    assert checks.rods_per_body(two_rods, "x", every_body=True) == "x: exactly one rod per body"
    assert checks.rods_per_body(free_too, "x") is None
    assert checks.rods_per_body(free_too, "x", every_body=True) == "x: exactly one rod per body"


def test_spring_checks_refuse_body_to_body_and_rod_body_springs():
    pair = Scene(parts=(Particles.of((bob(), bob((3.0, 0.0, 0.0)))), Springs.of((Spring(body=0, other=1, stiffness=1.0, rest_length=1.0),))))
    anchored = Scene(parts=(Particles.of((bob(),)), Springs.of((Spring(body=0, stiffness=1.0, rest_length=1.0),))))
    on_rod = Scene(parts=(Particles.of((bob(),)), anchored.part(Springs), Joints.of((ROD,))), gravity=G)
    assert checks.body_to_body_springs(pair, "x", " (anchors)") == \
        "x: springs between two bodies are not modelled (anchors)"
    assert checks.body_to_body_springs(anchored, "x") is None
    assert checks.springs_on_rod_bodies(on_rod, "x") == \
        "x: springs on a rod's body are not modelled"
    assert checks.springs_on_rod_bodies(pair, "x") is None


def test_linear_drag_names_what_it_acts_on():
    dragged = Scene(parts=(Particles.of((sphere(1.0),)),), linear_drag=0.1)
    assert checks.linear_drag(dragged, "x", "spheres", " (spin)") == \
        "x: linear drag on spheres is not modelled (spin)"
    assert checks.linear_drag(Scene(parts=(Particles.of((sphere(1.0),)),)), "x", "spheres") is None


# -- hinges --------------------------------------------------------------------------------------
def test_rod_start_accepts_a_rotation_about_the_axis_and_refuses_the_rest():
    swinging = Scene(parts=(Particles.of((bob(velocity=(0.0, 0.0, -2.0)),)), Joints.of((ROD,))), gravity=G)
    assert rod_start_refusal(swinging, "x") is None
    off_circle = Scene(parts=(Particles.of((bob((1.5, 0.0, 0.0)),)), Joints.of((ROD,))), gravity=G)
    assert rod_start_refusal(off_circle, "x") == (
        "x: body 0 must start at distance L from the anchor, perpendicular to the hinge axis "
        "(distance 1.5 m, rod length 1 m)")
    off_plane = Scene(parts=(Particles.of((bob((0.8, 0.6, 0.0)),)), Joints.of((ROD,))), gravity=G)
    assert "perpendicular to the hinge axis" in rod_start_refusal(off_plane, "x")
    second_off = Scene(parts=(Particles.of((bob(), bob((0.0, 0.0, -3.0)))), Joints.of((ROD, Joint(body=1, anchor=(0.0, 0.0, -1.0), length=1.0)))), gravity=G)
    assert rod_start_refusal(second_off, "x").startswith("x: body 1 must start at distance L")
    for velocity in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)):  # radial, along the axis
        off_arc = Scene(parts=(Particles.of((bob(velocity=velocity),)), Joints.of((ROD,))), gravity=G)
        assert rod_start_refusal(off_arc, "x") == \
            "x: body 0's initial velocity must be a rotation about the hinge axis"


def test_hinge_frames_hang_theta_zero_along_gravity_and_round_trip_the_start():
    bodies = (bob((0.6, 0.0, -0.8), (0.8, 0.0, 0.6)), bob((5.0, 1.0, 2.0), (1.0, 2.0, 3.0)))
    scene = Scene(parts=(Particles.of(bodies), Joints.of((ROD,))), gravity=G)
    frames = HingeFrames.from_scene(scene)
    # exact: g - axis (g . axis) = g (a product with 0), |g| = sqrt(9.81^2) = 9.81, g / |g|
    np.testing.assert_array_equal(frames.d, [[0.0, 0.0, -1.0]])
    np.testing.assert_array_equal(frames.g_plane, [9.81])
    theta, omega = frames.initial_angles(scene.part(Particles).position, scene.part(Particles).velocity)
    assert theta[0] == pytest.approx(math.atan2(0.6, 0.8), abs=1e-15)
    x, v = frames.cartesian(theta, omega, scene.part(Particles).position, scene.part(Particles).velocity)
    np.testing.assert_allclose(x, scene.part(Particles).position, atol=1e-15)
    np.testing.assert_allclose(v, scene.part(Particles).velocity, atol=1e-15)
    np.testing.assert_array_equal(x[1], scene.part(Particles).position[1])  # no rod: as given


def test_hinge_frames_of_a_scene_without_rods_are_empty_index_arrays():
    frames = HingeFrames.from_scene(Scene(parts=(Particles.of((bob(),)),)))
    assert frames.bodies.dtype.kind == "i" and frames.bodies.shape == (0,)
    assert frames.anchor.shape == frames.d.shape == frames.s.shape == (0, 3)
    theta, omega = frames.initial_angles(np.zeros((1, 3)), np.zeros((1, 3)))
    assert theta.shape == omega.shape == (0,)


def test_rod_length_errors_are_distance_minus_length_per_rod():
    scene = Scene(parts=(Particles.of((bob(),)), Joints.of((ROD,))), gravity=G)
    # exact: |(0, 0, -1.5)| - 1 = 0.5, binary-exact values
    np.testing.assert_array_equal(rod_length_errors(scene, np.array([[0.0, 0.0, -1.5]])), [0.5])


# -- contacts ------------------------------------------------------------------------------------
@pytest.mark.parametrize("e, mu", [(1.0, 0.0), (0.5, 0.3), (0.9, 1.2)])
def test_per_shape_coefficients_multiply_back_to_e_and_mu(e, mu):
    sqrt_e, sqrt_mu = per_shape_coefficients(ContactModel(restitution=e, friction=mu))
    assert sqrt_e * sqrt_e == pytest.approx(e, rel=2.3e-16, abs=0.0)
    assert sqrt_mu * sqrt_mu == pytest.approx(mu, rel=2.3e-16, abs=0.0)


# -- SPH lattices --------------------------------------------------------------------------------
BLOCK = FluidBlock(lower=(0.0, 0.0), upper=(0.2, 0.1), spacing=0.02, tank_width=0.5,
                   tank_height=0.3)


def test_fluid_particles_fill_the_block_one_per_cell():
    x = fluid_particles(BLOCK)
    assert x.shape == (10 * 5, 2)
    assert np.all((x > 0.0) & (x < [0.2, 0.1]))
    assert len(np.unique(np.round(x / BLOCK.spacing - 0.5).astype(int), axis=0)) == len(x)


def test_wall_particles_lie_outside_the_tank_wall_layers_deep():
    walls = wall_particles(BLOCK)
    outside = (walls[:, 1] < 0) | (walls[:, 0] < 0) | (walls[:, 0] > BLOCK.tank_width)
    assert outside.all()
    depth = WALL_LAYERS * BLOCK.spacing
    assert walls[:, 1].min() == pytest.approx(-depth + 0.5 * BLOCK.spacing)
    assert walls[:, 0].min() == pytest.approx(-depth + 0.5 * BLOCK.spacing)
    bottom = walls[walls[:, 1] < 0]
    assert len(np.unique(np.round(bottom[:, 1], 12))) == WALL_LAYERS


def test_hydrostatic_densities_give_the_weight_of_the_fluid_above():
    x = fluid_particles(BLOCK)
    rho = hydrostatic_densities(BLOCK, x, np.array([0.0, -9.81]))
    pressure = tait_pressure(rho, BLOCK.density, BLOCK.sound_speed)
    np.testing.assert_allclose(pressure, BLOCK.density * 9.81 * (0.1 - x[:, 1]), rtol=1e-9)


def test_plane_gravity_takes_x_y_in_2d_and_x_z_in_3d():
    fluid2 = Scene(parts=(Particles.of(()), BLOCK), dim=2, gravity=(0.5, -9.81, 0.0))
    fluid3 = Scene(parts=(Particles.of(()), BLOCK), dim=3, gravity=(0.5, 0.0, -9.81))
    np.testing.assert_array_equal(plane_gravity(fluid2), [0.5, -9.81])
    np.testing.assert_array_equal(plane_gravity(fluid3), [0.5, -9.81])


# -- every adapter gives the shared reasons --------------------------------------------------------
POINT_IN_CONTACT = spheres(second=sphere(2.0, radius=0.0, inertia=0.0))
SHARED_POINT_REASON = "contacts need every body to be a sphere of radius > 0 (body 1 has radius 0)"


@pytest.mark.parametrize("engine, who", [("refsim", "refsim"), ("mujoco", "mujoco adapter"),
                                         ("pybullet", "pybullet adapter"),
                                         ("pymunk", "pymunk"), ("taichi", "taichi adapter")])
def test_every_adapter_refuses_a_point_mass_in_contact_with_the_shared_reason(engine, who):
    # the spheres stay in the x-z plane, so pymunk (2D) reaches its contact checks too
    assert get_engine(engine).supports(POINT_IN_CONTACT, None) == f"{who}: {SHARED_POINT_REASON}"


@pytest.mark.parametrize("engine", ["mujoco", "pybullet"])
def test_rod_start_reason_is_shared_by_mujoco_and_pybullet(engine):
    off_circle = Scene(parts=(Particles.of((bob((1.5, 0.0, 0.0)),)), Joints.of((ROD,))), gravity=G)
    assert get_engine(engine).supports(off_circle, None) == \
        rod_start_refusal(off_circle, f"{engine} adapter")
