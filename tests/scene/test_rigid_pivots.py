"""The RigidPivots part: validation naming the field, and the start-on-anchor check."""
from __future__ import annotations

import numpy as np
import pytest

from refsim.scene import Scene
from refsim.scene.pivots import RigidPivots, check_on_anchor
from refsim.scene.rigid import RigidBodies


def _tilted_body(angle=0.3):
    q = [np.cos(angle / 2), 0.0, np.sin(angle / 2), 0.0]  # a turn of `angle` about world y
    return RigidBodies(mass=[1.0], inertia=[np.diag([1.0, 1.0, 2.0])], position=[[0, 0, 0]],
                       orientation=[q])


def test_pivot_on_its_anchor_is_accepted_and_found_in_the_scene():
    angle, point = 0.3, np.array([0.0, 0.0, -0.5])
    # the body point turned by `angle` about y, by hand: (z sin a, 0, z cos a) for (0, 0, z)
    anchor = [[point[2] * np.sin(angle), 0.0, point[2] * np.cos(angle)]]
    pivots = RigidPivots(body=[0], body_point=[point], anchor=anchor)
    check_on_anchor(pivots, _tilted_body(angle))
    scene = Scene(parts=(_tilted_body(angle), pivots))
    assert scene.part(RigidPivots) is pivots and scene.part_kinds() == {"rigid", "rigid_pivots"}
    assert "pivots" in scene.features() and not pivots.body.flags.writeable


def test_pivot_off_its_anchor_or_body_is_refused():
    body = _tilted_body()
    with pytest.raises(ValueError, match="must start on its anchor.*off by 0.5 m"):
        check_on_anchor(RigidPivots(body=[0], body_point=[[0, 0, -0.5]], anchor=[[0, 0, 0]]),
                        body)
    with pytest.raises(ValueError, match=r"rigid_pivots.body must be in \[0, 0\]"):
        check_on_anchor(RigidPivots(body=[1], body_point=[[0, 0, 0]], anchor=[[0, 0, 0]]), body)


@pytest.mark.parametrize("fields, message", [
    ({"body": [], "body_point": np.zeros((0, 3)), "anchor": np.zeros((0, 3))}, "at least one"),
    ({"body": [-1], "body_point": [[0, 0, 0]], "anchor": [[0, 0, 0]]}, "indices >= 0"),
    ({"body": [0, 0], "body_point": np.zeros((2, 3)), "anchor": np.zeros((2, 3))},
     "at most once"),
    ({"body": [0], "body_point": [[0, 0]], "anchor": [[0, 0, 0]]}, "rigid_pivots.body_point"),
    ({"body": [0], "body_point": [[0, 0, 0]], "anchor": [[np.nan, 0, 0]]}, "rigid_pivots.anchor"),
])
def test_bad_pivot_fields_name_the_field(fields, message):
    with pytest.raises(ValueError, match=message):
        RigidPivots(**fields)
