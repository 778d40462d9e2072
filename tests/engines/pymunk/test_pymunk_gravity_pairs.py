"""pymunk's n-body gravity (adapters/pymunk_engine/groups/gravity_pairs.py), what is pymunk's
own: point-mass bodies kicked by their velocity_func, planar scenes only (3D ones refused), and
the x-z plane mapped onto pymunk's plane. The checks shared with MuJoCo and pybullet (the
group's claim and cost, each step against refsim's symplectic_euler_dk to the rounding of one
update (bit for bit on x86-64), order 1 on the Kepler orbit, energy and angular momentum, the
figure-eight) are in tests/conformance/test_conformance_gravity_pairs.py; the scenes in
tests/conformance/gravity_scenes.py.
pymunk is imported on purpose: CI must have every engine (fail, never skip).
"""
import gravity_scenes
import numpy as np
import pymunk  # noqa: F401  (fail, never skip, without the engine)
from gravity_scenes import TWO_PI, kepler

from refsim.registry import get_engine
from refsim.scene import Particles

ENGINE = get_engine("pymunk")
INTEGRATOR = "symplectic_euler_dk"


def test_planar_gravity_scenes_in_pymunks_plane_and_3d_ones_refused():
    """The claim of the planar scene, the cost per step and the order: tests/conformance/
    test_conformance_gravity_pairs.py."""
    scene = kepler(0.5)
    s = ENGINE.build(scene, 0.01, INTEGRATOR, "").settings()
    assert s["space"]["damping"] == 1.0 and list(s["space"]["gravity"]) == [0.0, 0.0]
    assert s["plane"].startswith("refsim (x, y)")
    p = scene.part(Particles)
    tilted = scene.with_part(Particles(p.mass, p.position, p.velocity + [0.0, 0.0, 0.1]))
    assert ENGINE.supports(tilted, INTEGRATOR).startswith("pymunk is 2D")


def test_xz_plane_scene_maps_onto_pymunk_plane():
    """The same orbit turned into the x-z plane (a 3D scene at y = 0) gives the same numbers:
    only the axes are renamed. Bit for bit by construction: pymunk sees the same 2D numbers
    either way, and the adapter's pair kernel gets (x, y, 0) or (x, 0, z): two bodies take
    pair_accelerations' Python-float path, (dx^2 + dz^2) + dy^2 with the zero term in either
    place, exact additions of 0, so the same |d|^2 and the same operations after it."""
    scene = kepler(0.5)
    swap = [0, 2, 1]
    p = scene.part(Particles)
    xz = scene.with_part(Particles(p.mass, p.position[:, swap], p.velocity[:, swap]))
    a = gravity_scenes.run(ENGINE, scene, INTEGRATOR, "", TWO_PI, 200)
    b = gravity_scenes.run(ENGINE, xz, INTEGRATOR, "", TWO_PI, 200)
    assert np.array_equal(a["x"], b["x"][:, swap]) and np.array_equal(a["v"], b["v"][:, swap])
