"""RigidShapes: validation naming the field, features, the rolling group's scene checks."""
import numpy as np
import pytest

from refsim.scene import ContactModel, RigidBodies, Scene, Wall, Walls
from refsim.scene.rigid_shapes import RigidShapes, rolling_scene_refusal


def _disc(**kw):
    args = {"body": [0], "shape": ("cylinder",), "radius": [0.1], "half_length": [0.02]}
    return RigidShapes(**{**args, **kw})


def test_valid_part_features_and_lookup():
    part = _disc()
    assert part.shape == ("cylinder",) and part.features() == {"shapes"}
    assert not part.radius.flags.writeable
    rigid = RigidBodies(mass=[1.0], inertia=[np.eye(3)], position=[(0, 0, 0.1)],
                        orientation=[(1, 0, 0, 0)])
    scene = Scene(parts=(Walls.of((Wall((0, 0, 0), (0, 0, 1)),)), rigid, part), contact=ContactModel(0.0, 0.5), gravity=(0, 0, -9.81))
    assert scene.part(RigidShapes) is part and rolling_scene_refusal(scene, "x") is None


@pytest.mark.parametrize("kw, field", [
    ({"shape": ("box",)}, "rigid_shapes.shape"),
    ({"radius": [0.0]}, "rigid_shapes.radius"),
    ({"half_length": [0.0]}, "rigid_shapes.half_length"),
    ({"shape": ("sphere",)}, "rigid_shapes.half_length"),  # a sphere needs half_length 0
    ({"body": [-1]}, "rigid_shapes.body"),
    ({"body": []}, "rigid_shapes.body"),
])
def test_bad_input_names_the_field(kw, field):
    with pytest.raises(ValueError, match=field):
        _disc(**kw)


def test_sphere_defaults_to_zero_half_length():
    assert RigidShapes(body=[0], shape=("sphere",), radius=[0.2]).half_length.tolist() == [0.0]


def test_refusal_off_plane():
    rigid = RigidBodies(mass=[1.0], inertia=[np.eye(3)], position=[(0, 0.5, 0.1)],
                        orientation=[(1, 0, 0, 0)])
    scene = Scene(parts=(Walls.of((Wall((0, 0, 0), (0, 0, 1)),)), rigid, _disc()), contact=ContactModel(0.0, 0.5))
    assert "planar motion only" in rolling_scene_refusal(scene, "x")
