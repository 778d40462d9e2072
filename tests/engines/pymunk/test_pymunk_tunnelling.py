"""pymunk against thin plates (issue 28 tunnelling; adapters/pymunk_engine/plates.py): 2D, no
continuous detection: its discrete detection's mid-plane rule, the bounce from the overlapped
pose, and what it refuses. Scenes from tests/engines/common/tunnel_scenes.py (lanes along z,
in pymunk's x-z plane): each sphere's previous step ends 1 um before the entry face, speeds
as ratios of (w + 2r) / dt; r = 5 cm, w = 2 cm, dt = 1 ms. Measured on pymunk 7.3.1.
"""
import numpy as np
import pymunk  # noqa: F401  (fail, never skip, without the engine)
from tunnel_scenes import DT, GAP, R, W, run, scene, speeds

from refsim.engine import ContactInfo
from refsim.registry import get_engine
from refsim.scene import Plates, Scene

RULE = 0.5 + GAP / (W + 2 * R)  # mid-plane rule: through iff v dt - gap > w/2 + r


def test_discrete_tunnels_past_the_mid_plane():
    """A circle found overlapping with its centre past the mid-plane is pushed out of the far
    face (least penetration): through iff v dt > w/2 + r + gap; 2.4e-5 m of travel either
    side decides it; every ratio above tunnels up to 100x, with its speed bit for bit (no
    clamp)."""
    ratios = np.array([0.1, 0.3, RULE - 2e-4, RULE + 2e-4, 0.75, 0.999, 1.001, 3.0, 100.0])
    through, vn, *_ = run("pymunk", "", ratios)
    assert list(through > 0) == [False] * 3 + [True] * 6
    assert np.array_equal(vn[3:], speeds(ratios[3:]))


def test_discrete_bounce_keeps_the_overlap():
    """Position correction off (collision_bias 1): the bounce starts from the overlapped pose
    found after the decisive step (drift-kick: the step that finds it reverses v after its
    drift), so a bounced sphere trails a face-placed theory by its overlap depth."""
    ratio, steps = 0.3, 10
    v = speeds([ratio])[0]
    through, vn, *_ = run("pymunk", "", [ratio], steps=steps)
    overlapped = -(0.5 * W + R) - GAP + v * DT
    expected = overlapped - v * DT * (steps - 2)
    # positions are sums of steps of v dt (12 roundings of ~0.4 m): 1e-13 m
    assert abs(through[0] - expected) < 1e-13 and vn[0] == -v


def test_oblique_plate_in_the_plane():
    """A plate with normal (0.6, 0, 0.8): the rectangle follows the normal (a slow sphere comes
    straight back, a fast one tunnels past the mid-plane)."""
    nrm = np.array([0.6, 0.0, 0.8])
    through, vn, v, _ = run("pymunk", "", [0.3, 0.6], normal=nrm)
    assert through[0] < 0 < through[1]
    # e = 1 (sqrt(1) per shape); the impulse along the rectangle's face normal, which is
    # the plate normal to round-off of the corner arithmetic
    assert abs(vn[0] + speeds([0.3])[0]) < 1e-12
    assert np.linalg.norm(v[0] - vn[0] * nrm) < 1e-12


def test_settings_and_formulations():
    eng = get_engine("pymunk")
    sc = scene([1.0])[0]
    assert eng.formulations(sc) == ("",)  # no continuous detection to offer
    *_, s = run("pymunk", "", [1.0], steps=1)
    assert ContactInfo.of(s).detection == "discrete" and s["plate_side"] == "nearest"
    assert "no continuous collision detection" in s["ccd"]


def test_refusals():
    """Plates off pymunk's plane (or spheres off it), and plates without a contact model."""
    eng = get_engine("pymunk")
    sc, lanes, n = scene([1.0])
    particles, plates = sc.parts
    tilted = Plates(center=plates.center, normal=[[0.6, 0.8, 0.0]],
                    thickness=plates.thickness, half_size=plates.half_size)
    assert "a plate must have its centre and normal in pymunk's plane" in eng.supports(
        Scene(parts=(particles, tilted), contact=sc.contact, gravity=(0.0, 0.0, 0.0)))
    bare = Scene(parts=sc.parts, gravity=(0.0, 0.0, 0.0))
    assert "plates without a contact model" in eng.supports(bare)
    lifted = scene([1.0, 2.0], normal=(0.0, 0.0, 1.0))[0]  # lanes then along x: in the plane
    assert eng.supports(lifted) is None
