"""The scene of typed parts: each part validates its fields (a bad one is rejected by name),
stores read-only arrays built once, and contributes its features and kind; the record API of
the cases (Body, Spring, Joint, Wall, ...) keeps its values, messages and features."""
import math

import numpy as np
import pytest

from refsim.registry import case_names, get_case
from refsim.scene import (PART_KINDS, Body, ContactModel, FluidBlock, Grid, Joint, Joints,
                          Material, Particles, Plasticity, RigidBodies, Scene, Spring,
                          SpringNetwork, Springs, TriangleMesh, Wall, Walls)

SQUARE = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
STEEL = Material(youngs_modulus=2e11, poisson_ratio=0.3, density=7850.0)


def particles(**kw):
    return Particles(**{"mass": [1.0, 2.0], "position": [[0, 0, 0], [1, 0, 0]], **kw})


def springs(**kw):
    return Springs(**{"body": [0], "other": [-1], "anchor": [[0, 0, 1]], "stiffness": [10.0],
                      "rest_length": [0.5], "damping": [0.0], **kw})


def joints(**kw):
    return Joints(**{"body": [0], "anchor": [[0, 0, 1]], "length": [1.0],
                     "axis": [[0, 1, 0]], "kinds": ("hinge",), **kw})


def walls(**kw):
    return Walls(**{"point": [[0, 0, 0]], "normal": [[0, 0, 2]], **kw})


def rigid(**kw):
    return RigidBodies(**{"mass": [2.0], "inertia": [np.diag([1.0, 2.0, 3.0])],
                          "position": [[0, 0, 1]], "orientation": [[1.0, 0, 0, 0]], **kw})


def network(**kw):
    return SpringNetwork(**{"positions": SQUARE, "masses": 0.1,
                            "edges": [[0, 1], [1, 2], [2, 3], [3, 0]], "stiffness": 100.0,
                            "hinges": [[0, 1, 2]], "hinge_stiffness": 1e-3,
                            "dihedrals": [[1, 0, 2, 3]], "dihedral_stiffness": 1e-3,
                            "pinned": [0], **kw})


def mesh(**kw):
    return TriangleMesh(**{"vertices": SQUARE, "triangles": [[0, 1, 2], [0, 2, 3]],
                           "material": STEEL, **kw})


def grid(**kw):
    return Grid(**{"shape": (5, 4), "spacing": 0.1, "model": "diffusion",
                   "fields": {"T": np.zeros((5, 4))}, "boundary": "dirichlet", **kw})


def material(**kw):
    return Material(**{"youngs_modulus": 1e6, "poisson_ratio": 0.3, "density": 1000.0, **kw})


BUILDERS = {"particles": particles, "springs": springs, "joints": joints, "walls": walls,
            "rigid": rigid, "network": network, "mesh": mesh, "grid": grid,
            "material": material}

BAD_FIELDS = [  # (builder, override, the field the message must name)
    ("particles", {"mass": [1.0, 0.0]}, "particles.mass"),
    ("particles", {"position": [[0, 0, 0]]}, "particles.position"),
    ("particles", {"velocity": [[0, 0, math.nan]] * 2}, "particles.velocity"),
    ("particles", {"radius": [0.1, -0.1]}, "particles.radius"),
    ("particles", {"inertia": [-1.0, 0.0]}, "particles.inertia"),
    ("particles", {"angular_velocity": np.zeros((2, 2))}, "particles.angular_velocity"),
    ("springs", {"stiffness": [0.0]}, "springs.stiffness"),
    ("springs", {"rest_length": [-1.0]}, "springs.rest_length"),
    ("springs", {"damping": [-0.1]}, "springs.damping"),
    ("springs", {"anchor": [[0, 0]]}, "springs.anchor"),
    ("springs", {"other": [-2]}, "springs.other"),
    ("joints", {"length": [0.0]}, "joints.length"),
    ("joints", {"axis": [[0, 0, 0]]}, "joints.axis"),
    ("joints", {"kinds": ("ball",)}, "joints.kinds"),
    ("walls", {"normal": [[0, 0, 0]]}, "walls.normal"),
    ("walls", {"point": [[0, math.inf, 0]]}, "walls.point"),
    ("rigid", {"mass": [-2.0]}, "rigid.mass"),
    ("rigid", {"inertia": [[[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]]}, "rigid.inertia"),
    ("rigid", {"inertia": [np.diag([1.0, -1.0, 1.0])]}, "rigid.inertia"),
    ("rigid", {"inertia": [np.eye(2)]}, "rigid.inertia"),
    ("rigid", {"orientation": [[1.0, 1e-4, 0, 0]]}, "rigid.orientation"),
    ("rigid", {"orientation": [[1.0, 0, 0]]}, "rigid.orientation"),
    ("rigid", {"position": [[0, 0, 1], [0, 0, 2]]}, "rigid.position"),
    ("rigid", {"velocity": [[0, 0, math.nan]]}, "rigid.velocity"),
    ("rigid", {"angular_velocity": [[0, 0]]}, "rigid.angular_velocity"),
    ("network", {"positions": SQUARE[:, :2]}, "network.positions"),
    ("network", {"masses": [0.1, 0.1, 0.0, 0.1]}, "network.masses"),
    ("network", {"velocities": np.zeros((3, 3))}, "network.velocities"),
    ("network", {"edges": [[0, 4]]}, "network.edges"),
    ("network", {"edges": [[1, 1]]}, "network.edges"),
    ("network", {"edges": [[0.5, 1]]}, "network.edges"),
    ("network", {"stiffness": -1.0}, "network.stiffness"),
    ("network", {"rest_length": [1.0, 1.0, -1.0, 1.0]}, "network.rest_length"),
    ("network", {"damping": -1.0}, "network.damping"),
    ("network", {"hinges": [[0, 1]]}, "network.hinges"),
    ("network", {"hinge_stiffness": None}, "network.hinge_stiffness"),
    ("network", {"hinge_rest_angle": 4.0}, "network.hinge_rest_angle"),
    ("network", {"dihedrals": [[0, 1, 2, 2]]}, "network.dihedrals"),
    ("network", {"dihedral_stiffness": 0.0}, "network.dihedral_stiffness"),
    ("network", {"dihedral_rest_angle": -4.0}, "network.dihedral_rest_angle"),
    ("network", {"pinned": [0, 0]}, "network.pinned"),
    ("network", {"pinned": [7]}, "network.pinned"),
    ("material", {"youngs_modulus": 0.0}, "material.youngs_modulus"),
    ("material", {"poisson_ratio": 0.5}, "material.poisson_ratio"),
    ("material", {"poisson_ratio": -1.0}, "material.poisson_ratio"),
    ("material", {"density": -1.0}, "material.density"),
    ("material", {"strain": "hencky"}, "material.strain"),
    ("material", {"plasticity": "yes"}, "material.plasticity"),
    ("mesh", {"vertices": SQUARE[:, :2]}, "mesh.vertices"),
    ("mesh", {"triangles": [[0, 1, 4]]}, "mesh.triangles"),
    ("mesh", {"triangles": [[0, 1, 1]]}, "mesh.triangles"),
    ("mesh", {"vertices": [[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]]}, "mesh.triangles"),
    ("mesh", {"velocities": np.zeros((4, 2))}, "mesh.velocities"),
    ("mesh", {"thickness": 0.0}, "mesh.thickness"),
    ("mesh", {"material": "steel"}, "mesh.material"),
    ("grid", {"shape": (5, 2)}, "grid.shape"),
    ("grid", {"shape": (3, 3, 3, 3)}, "grid.shape"),
    ("grid", {"spacing": (0.1, 0.0)}, "grid.spacing"),
    ("grid", {"spacing": (0.1, 0.1, 0.1)}, "grid.spacing"),
    ("grid", {"boundary": "robin"}, "grid.boundary"),
    ("grid", {"boundary": (("periodic", "dirichlet"), ("neumann", "neumann"))}, "grid.boundary"),
    ("grid", {"model": ""}, "grid.model"),
    ("grid", {"fields": {}}, "grid.fields"),
    ("grid", {"fields": {"T": np.zeros((4, 5))}}, "grid.fields"),
    ("grid", {"fields": {"T": np.full((5, 4), np.nan)}}, "grid.fields"),
    ("grid", {"origin": (0.0, math.inf)}, "grid.origin"),
    ("grid", {"coefficients": {"diffusivity": math.nan}}, "grid.coefficients"),
]


ACCEPTED = {  # per builder: fields as stored, given values kept and defaults filled in by hand
    "particles": {"mass": [1.0, 2.0], "velocity": np.zeros((2, 3)), "radius": [0.0, 0.0],
                  "inertia": [0.0, 0.0], "angular_velocity": np.zeros((2, 3))},
    "springs": {"body": [0], "other": [-1], "anchor": [[0.0, 0.0, 1.0]],
                "rest_length": [0.5]},
    "joints": {"length": [1.0], "axis": [[0.0, 1.0, 0.0]], "kinds": ("hinge",)},
    "walls": {"point": [[0.0, 0.0, 0.0]], "normal": [[0.0, 0.0, 1.0]]},  # (0, 0, 2) made unit
    "rigid": {"mass": [2.0], "inertia": [np.diag([1.0, 2.0, 3.0])],
              "velocity": [[0.0, 0.0, 0.0]], "angular_velocity": [[0.0, 0.0, 0.0]]},
    "network": {"masses": [0.1] * 4, "stiffness": [100.0] * 4, "damping": [0.0] * 4,
                "rest_length": [1.0] * 4, "pinned": [0], "velocities": np.zeros((4, 3))},
    "mesh": {"triangles": [[0, 1, 2], [0, 2, 3]], "thickness": 1.0,
             "velocities": np.zeros((4, 3))},
    "grid": {"shape": (5, 4), "spacing": (0.1, 0.1), "origin": (0.0, 0.0),
             "boundary": (("dirichlet", "dirichlet"),) * 2},
    "material": {"youngs_modulus": 1e6, "strain": "linear", "plasticity": None},
}


@pytest.mark.parametrize("builder", sorted(BUILDERS))
def test_good_data_is_stored_as_given_with_defaults_filled_in(builder):
    part = BUILDERS[builder]()
    assert part == BUILDERS[builder]()  # equal by value
    for field, value in ACCEPTED[builder].items():
        stored = getattr(part, field)
        if isinstance(stored, np.ndarray):
            assert np.array_equal(stored, value), field
        else:
            assert stored == value, field


@pytest.mark.parametrize("builder,override,field", BAD_FIELDS)
def test_a_bad_field_is_rejected_by_name(builder, override, field):
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        BUILDERS[builder](**override)


def test_plasticity_bounds_are_named():
    assert Plasticity(yield_stress=0.0).hardening == 0.0
    for kw, name in (({"yield_stress": -1.0}, "yield_stress"),
                     ({"yield_stress": 1e6, "hardening": -1.0}, "hardening")):
        with pytest.raises(ValueError, match=f"plasticity.{name}"):
            Plasticity(**kw)


def _arrays(part):
    values = [getattr(part, f) for f in part.__dataclass_fields__]
    values += [a for v in values if hasattr(v, "values") for a in v.values()]  # grid fields
    return [v for v in values if isinstance(v, np.ndarray)]


@pytest.mark.parametrize("builder", sorted(set(BUILDERS) - {"material"}))
def test_every_stored_array_is_read_only(builder):
    arrays = _arrays(BUILDERS[builder]())
    assert arrays
    for arr in arrays:
        assert not arr.flags.writeable
        with pytest.raises(ValueError, match="read-only"):
            arr.reshape(-1)[:1] = 0


def test_parts_copy_their_input():
    x = SQUARE.copy()
    net = network(positions=x)
    x[0, 0] = 5.0
    assert net.positions[0, 0] == 0.0


def test_rigid_orientation_is_stored_normalised_and_inertia_kept_exactly():
    q = np.array([[1.0 + 5e-10, 0.0, 0.0, 0.0], [0.5, 0.5, 0.5, 0.5]])
    inertia = np.array([np.diag([1.0, 2.0, 3.0]), [[2.0, 0.1, 0], [0.1, 2.0, 0], [0, 0, 1]]])
    body = rigid(mass=[1.0, 1.0], inertia=inertia, position=np.zeros((2, 3)), orientation=q)
    assert np.abs(np.linalg.norm(body.orientation, axis=1) - 1.0).max() <= 2.3e-16
    assert np.array_equal(body.inertia, inertia)  # exactly symmetric input: unchanged
    assert np.array_equal(body.velocity, np.zeros((2, 3)))


def test_network_rest_values_default_to_the_initial_shape():
    """Rest lengths are the square's sides; the turning angle at a square's corner is pi/2;
    the two triangles of a flat square meet at dihedral angle 0, folded square: +-pi/2."""
    net = network(hinge_rest_angle=None, dihedral_rest_angle=None)
    assert np.allclose(net.rest_length, 1.0, rtol=0, atol=1e-15)
    assert net.hinge_rest_angle == pytest.approx([math.pi / 2], abs=1e-15)
    assert net.dihedral_rest_angle == pytest.approx([0.0], abs=1e-15)
    fold = network(  # triangles (2, 0, 1) in z = 0 and (3, 1, 0) in y = 0: a right angle
        positions=[[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], edges=[[0, 1]], hinges=None,
        dihedrals=[[2, 0, 1, 3]])
    assert abs(fold.dihedral_rest_angle[0]) == pytest.approx(math.pi / 2, abs=1e-15)
    assert net.edge_kinds() == {"stretch", "hinge", "dihedral"}
    assert fold.edge_kinds() == {"stretch", "dihedral"}


def test_grid_broadcasts_spacing_and_boundary_per_axis():
    g = grid(boundary=("periodic", "periodic"), spacing=0.5, origin=(1.0, 2.0))
    assert g.spacing == (0.5, 0.5) and g.origin == (1.0, 2.0)
    assert g.boundary == (("periodic", "periodic"),) * 2
    mixed = grid(boundary=(("dirichlet", "neumann"), ("periodic", "periodic")))
    assert mixed.boundary[0] == ("dirichlet", "neumann")


# -- the scene: record API kept --------------------------------------------------------------
BALL = Body(mass=1.0, position=(0.0, 0.0, 1.0), velocity=(1.0, 0.0, 0.0), radius=0.1,
            inertia=0.004, angular_velocity=(0.0, 2.0, 0.0))
TWO = (BALL, Body(mass=3.0, position=(1.0, 0.0, 1.0)))

OLD_MESSAGES = [  # today's messages, unchanged
    (lambda: Scene(parts=(Particles.of(()),)), "scene.parts must hold at least one part with "
     "bodies (particles, a fluid, rigid bodies, a network, a mesh, a grid or a plugin's part), "
     "got none"),
    (lambda: Scene(parts=(Particles.of(TWO), Springs.of((Spring(body=2, stiffness=1.0, rest_length=0.0),)))),
     "spring body index must be in [0, 1], got 2"),
    (lambda: Scene(parts=(Particles.of(TWO), Joints.of((Joint(body=-1, anchor=(0, 0, 0), length=1.0),)))),
     "joint body index must be in [0, 1], got -1"),
    (lambda: Scene(parts=(Particles.of(TWO),), dim=4), "scene.dim must be 2 or 3, got 4"),
    (lambda: Scene(parts=(Particles.of(TWO),), linear_drag=-1), "scene.linear_drag must be a finite number >= "
     "0, got -1.0"),
    (lambda: Scene(parts=(Particles.of(TWO),), gravity=(0, 0)), "scene.gravity must have 3 components, got 2"),
    (lambda: Body(mass=0.0, position=(0, 0, 0), name="bob"),
     "bob.mass must be a finite number > 0, got 0.0"),
    (lambda: Wall(point=(0, 0, 0), normal=(0, 0, 0)), "wall.normal must be a non-zero vector"),
    (lambda: ContactModel(restitution=2.0), "contact.restitution must be in [0, 1], got 2.0"),
    (lambda: Joint(body=0, anchor=(0, 0, 0), length=1.0, kind="ball"),
     "joint.kind must be one of ['hinge'], got 'ball'"),
    (lambda: FluidBlock((0, 0), (2, 1), 0.1, 1.0, 1.0), "fluid block must lie inside the tank"),
]


@pytest.mark.parametrize("build,message", OLD_MESSAGES)
def test_todays_validation_messages_are_kept(build, message):
    with pytest.raises(ValueError) as err:
        build()
    assert str(err.value) == message


def _case_scenes():
    for name in case_names():
        case = get_case(name)
        for variant in case.quick_variants:
            yield f"{name}:{variant}", case.scene(case.variant_params(variant))


@pytest.mark.parametrize("label,scene", list(_case_scenes()))
def test_case_scenes_hold_each_part_once_as_read_only_arrays(label, scene):
    """Every case's scene: each part held once (asked for by its class, the same object each
    time), array parts read-only and float64 where they hold numbers; records made on demand
    equal the arrays."""
    for part in scene.parts:
        assert scene.parts_of(type(part)).count(part) == 1
        if not getattr(type(part), "many", False):
            assert scene.part(type(part)) is part
    particles = scene.part(Particles)
    if particles is not None:
        for attr in ("mass", "position", "velocity", "radius", "inertia", "angular_velocity"):
            arr = getattr(particles, attr)
            assert arr is getattr(scene.part(Particles), attr) and not arr.flags.writeable
            assert arr.dtype == np.float64 and len(arr) == len(particles)
        assert Particles.of(particles.to_records()) == particles
    for cls in (Springs, Joints, Walls):
        part = scene.part(cls)
        assert part is None or cls.of(part.to_records()) == part


def test_a_part_is_asked_for_by_its_class():
    two = Scene(parts=(grid(), grid(model="wave", fields={"w": np.zeros((5, 4))})))
    assert len(two.parts_of(Grid)) == 2
    with pytest.raises(ValueError, match=r"scene holds 2 Grid parts: ask for them with "
                                         r"scene.parts_of\(Grid\)"):
        two.part(Grid)
    scene = Scene(parts=(Particles.of(TWO), None, Springs.of(())))  # None and empty: dropped
    assert scene.parts == (scene.part(Particles),) and scene.part(Springs) is None
    assert scene.with_part(Springs.of((Spring(0, 1.0, 0.0),))).part(Springs) is not None


def test_a_scene_from_parts_equals_the_scene_from_records():
    spring = Spring(body=0, stiffness=5.0, rest_length=0.2, other=1, damping=0.1)
    rod = Joint(body=1, anchor=(0, 0, 2), length=1.0, axis=(0, 1, 1))
    wall = Wall(point=(0, 0, 0), normal=(1, 1, 0))
    records = Scene(parts=(Particles.of(TWO), Springs.of((spring,)), Joints.of((rod,)), Walls.of((wall,))))
    parts = Scene(parts=(Particles.of(Particles.from_records(TWO)), Springs.of(Springs.from_records((spring,))), Joints.of(Joints.from_records((rod,))), Walls.of(Walls.from_records((wall,)))))
    assert parts == records and hash(parts) == hash(records)
    assert np.array_equal(parts.part(Walls).normal[0], wall.normal)  # unit rows kept bit-exact
    assert Scene(parts=(Particles.of(TWO),), gravity=(0, 0, -1)) != records


FEATURES = [  # (scene, features, part kinds)
    (Scene(parts=(Particles.of(TWO[:1]),), gravity=(0, 0, -9.81)), {"gravity"}, {"particles"}),
    (Scene(parts=(Particles.of(TWO[:1]),), linear_drag=0.5), {"drag"}, {"particles"}),
    (Scene(parts=(Particles.of(TWO[:1]), Springs.of((Spring(0, 1.0, 0.0),)))), {"springs"},
     {"particles", "springs"}),
    (Scene(parts=(Particles.of(TWO[:1]), Joints.of((Joint(0, (0, 0, 2), 1.0),))), gravity=(0, 0, -1)),
     {"gravity", "joints"}, {"particles", "joints"}),
    (Scene(parts=(Particles.of(TWO), Walls.of((Wall((0, 0, 0), (0, 0, 1)),))), contact=ContactModel()),
     {"contacts", "walls"}, {"particles", "walls"}),
    (Scene(parts=(FluidBlock((0, 0), (1, 2), 0.1, 4.0, 3.0),), gravity=(0, -9.81, 0), dim=2),
     {"fluid", "walls", "gravity"}, {"fluid"}),
    (Scene(parts=(rigid(),)), {"rigid"}, {"rigid"}),
    (Scene(parts=(network(),), gravity=(0, 0, -9.81)), {"networks", "gravity"},
     {"networks"}),
    (Scene(parts=(mesh(),)), {"fem"}, {"meshes"}),
    (Scene(parts=(mesh(material=material(plasticity=Plasticity(1e5))),)), {"fem", "plasticity"},
     {"meshes"}),
    (Scene(parts=(grid(),)), {"grid", "diffusion"}, {"grids"}),
    (Scene(parts=(rigid(), grid(model="wave"))), {"rigid", "grid", "wave"},
     {"rigid", "grids"}),
]


@pytest.mark.parametrize("scene,features,kinds", FEATURES)
def test_features_and_part_kinds_come_from_the_parts(scene, features, kinds):
    assert scene.features() == features
    assert scene.part_kinds() == kinds
    assert kinds <= set(PART_KINDS)


@pytest.mark.parametrize("other", [rigid(), network(), mesh(),
                                   FluidBlock((0, 0), (1, 2), 0.1, 4.0, 3.0)])
def test_a_scene_mixing_two_moving_kinds_is_rejected(other):
    with pytest.raises(ValueError, match="one kind of moving bodies"):
        Scene(parts=(Particles.of(TWO), other))
    with pytest.raises(ValueError, match="one kind of moving bodies"):
        Scene(parts=(network(), mesh()))


def test_scene_parts_are_checked():
    with pytest.raises(ValueError, match="scene.parts must hold parts"):
        Scene(parts=(Particles.of(TWO), "springs"))
    with pytest.raises(ValueError, match="at most one Particles part, got 2"):
        Scene(parts=(Particles.of(TWO), Particles.of(TWO)))
    with pytest.raises(ValueError, match="grids' field names must be distinct"):
        Scene(parts=(grid(), grid(model="wave")))
    with pytest.raises(ValueError, match="scene.contact must be a ContactModel"):
        Scene(parts=(Particles.of(TWO),), contact=0.5)


def test_plane_checks_accept_planar_motion_and_refuse_spin_out_of_it():
    flat = Scene(parts=(Particles.of((Body(1.0, (1.0, 0.0, 0.0), (0.0, 0.0, 1.0),
                              angular_velocity=(0.0, 3.0, 0.0)),)), Joints.of((Joint(0, (0, 0, 0), 1.0, axis=(0, -2, 0)),))), gravity=(0, 0, -9.81))
    assert flat.stays_in_xz_plane() and not flat.stays_in_plane(2)
    spun = Scene(parts=(Particles.of((Body(1.0, (1.0, 0.0, 0.0), angular_velocity=(1.0, 0.0, 0.0)),)),))
    assert not spun.stays_in_xz_plane()
    assert Scene(parts=(network(),)).stays_in_plane(2)
    assert not Scene(parts=(rigid(),)).stays_in_plane(2)  # rigid bodies: not analysed


@pytest.mark.parametrize("kind,build", [("rigid", lambda **kw: Scene(parts=(rigid(**kw),))),
                                        ("network", lambda **kw: Scene(parts=(network(**kw),))),
                                        ("mesh", lambda **kw: Scene(parts=(mesh(**kw),))),
                                        ("grid", lambda **kw: Scene(parts=(grid(**kw),)))])
def test_scenes_of_new_parts_compare_and_hash_by_value(kind, build):
    changed = {"rigid": {"mass": [3.0]}, "network": {"stiffness": 50.0},
               "mesh": {"thickness": 0.5}, "grid": {"fields": {"T": np.ones((5, 4))}}}[kind]
    assert build() == build() and hash(build()) == hash(build())
    assert build(**changed) != build()
