"""pybullet against thin plates (issue 28 tunnelling; adapters/pybullet_engine/plates.py): the
discrete detection's mid-plane rule, the "ccd" formulation (swept spheres, continuous), the
defaults that break either, and the multibody speed clamp the spheres group avoids. Scenes
from tests/engines/common/tunnel_scenes.py: each sphere's previous step ends 1 um before the
entry face, speeds as ratios of (w + 2r) / dt; r = 5 cm, w = 2 cm, dt = 1 ms unless stated.
Measured on pybullet 3.2.7.
"""
import numpy as np
import pybullet  # noqa: F401  (fail, never skip, without the engine)
from tunnel_scenes import DT, GAP, R, W, build, run, speeds

from refsim.engine import ContactInfo
from refsim.registry import get_engine

RULE = 0.5 + GAP / (W + 2 * R)  # mid-plane rule: through iff v dt - gap > w/2 + r


def test_discrete_tunnels_past_the_mid_plane():
    """An overlap found with the centre past the mid-plane is pushed out of the far face:
    through iff v dt > w/2 + r + gap, ratio 0.5 + gap / (w + 2r), half the geometric rule.
    2.4e-5 m of travel either side decides it; every ratio above tunnels up to 100x."""
    ratios = np.array([0.1, 0.3, RULE - 2e-4, RULE + 2e-4, 0.75, 0.999, 1.001, 3.0, 100.0])
    through, *_ = run("pybullet", "", ratios)
    assert list(through > 0) == [False] * 3 + [True] * 6


def test_discrete_bounce_keeps_the_overlap():
    """Contact ERP 0: the bounce starts from the overlapped pose found at the step's end (the
    impulse reverses v at the next step, nothing pushes the sphere out), so a bounced sphere
    trails the one a face-placed theory gives by its overlap depth."""
    ratio = 0.3
    v = speeds([ratio])[0]
    steps = 10
    through, vn, *_ = run("pybullet", "", [ratio], steps=steps)
    overlapped = -(0.5 * W + R) - GAP + v * DT  # the centre at the end of the decisive step
    expected = overlapped - v * DT * (steps - 2)  # e = 1, reversed from the next step on
    # positions are sums of steps of v dt (12 roundings of ~0.4 m): 1e-13 m
    assert abs(through[0] - expected) < 1e-13 and vn[0] == -v


def test_ccd_stops_every_sphere_up_to_100x():
    """ccdSweptSphereRadius = r, allowedCcdPenetration 0: no sphere from 0.05 to 100 times
    (w + 2r) / dt gets through (the discrete formulation: 50 of the 60)."""
    ratios = np.concatenate([np.linspace(0.05, 1.0, 20), np.geomspace(1.0, 100.0, 40)])
    through, *_ = run("pybullet", "ccd", ratios)
    assert np.all(through < 0)
    discrete, *_ = run("pybullet", "", ratios)
    assert np.sum(discrete > 0) == 50


def test_ccd_default_penetration_allowance_lets_small_spheres_through():
    """Bullet ignores a sweep hit that would penetrate less than allowedCcdPenetration (default
    0.04 m, absolute): a 5 mm sphere against a 2 mm plate then tunnels at 0.55 to 3 times
    (w + 2r) / dt. The adapter's 0 stops them; planted back to 0.04, they go through."""
    ratios = np.array([0.3, 0.55, 1.0, 2.0, 3.0, 5.0, 100.0])
    kw = dict(r=0.005, w=0.002)
    fixed, *_ = run("pybullet", "ccd", ratios, **kw)
    assert np.all(fixed < 0)

    def default_allowance(sim):
        sim.p.setPhysicsEngineParameter(allowedCcdPenetration=0.04,
                                        physicsClientId=sim.client)
    planted, *_ = run("pybullet", "ccd", ratios, hook=default_allowance, **kw)
    assert list(planted > 0) == [False, True, True, True, True, False, False]


def test_ccd_rebound_is_the_landing_speed_not_the_impact_speed():
    """A swept hit moves the sphere to the surface with velocity (distance to it) / dt; it
    rebounds at e times that (e = 1 exactly here), whatever the impact speed. Below the
    motion threshold r / 2 per step (ratio 0.2) the discrete contact bounces it at e v."""
    gap = 3e-3
    ratios = np.array([0.2, 0.5, 1.0, 10.0, 100.0])
    through, vn, *_ = run("pybullet", "ccd", ratios, gap=gap, steps=60)
    assert np.all(through < 0)
    assert vn[0] == -speeds([0.2])[0]
    # the landing speed gap / dt, reversed: to the rounding of the positions (1e-12 m / dt)
    assert np.all(np.abs(vn[1:] + gap / DT) < 1e-9)


def test_plate_collision_margin_is_zero():
    """pybullet's boxes keep a 1 mm margin: a 0.4 mm plate collides as 2 mm thick (a sphere
    1 um away is reported 0.8 mm deep). The adapter sets collisionMargin 0: the distance is
    exact; planted back to 1 mm, the error returns."""
    sim, lanes, n = build("pybullet", "", [0.0], r=0.001, w=0.0004)
    try:
        p, cid = sim.p, sim.client
        sphere, plate = sim.handles[0][0], sim.plate_ids[0]
        gap = GAP  # at ratio 0 the scene starts the sphere this far from the face

        def distance():
            return min(c[8] for c in p.getClosestPoints(sphere, plate, 1.0,
                                                         physicsClientId=cid))
        # GJK on a sphere (point + margin) and a box face: round-off of 1e-3 m coordinates
        assert abs(distance() - gap) < 1e-12
        p.changeDynamics(plate, -1, collisionMargin=0.001, physicsClientId=cid)
        assert distance() < -7e-4  # measured -8.2e-4: the plate thickened to 2 mm
    finally:
        sim.close()


def test_settings_declare_detection_side_and_no_clamp():
    for form, detection in (("", "discrete"), ("ccd", "continuous")):
        *_, s = run("pybullet", form, [100.0], steps=1)
        assert ContactInfo.of(s).detection == detection and s["plate_side"] == "nearest"
        assert "none: every sphere is a maximal-coordinate" in s["speed_clamp"]
    # no clamp: a sphere at 100x (12000 m/s) flies through with its speed bit for bit
    through, vn, *_ = run("pybullet", "", [100.0])
    assert through[0] > 0 and vn[0] == speeds([100.0])[0]


def test_multibody_base_is_clamped_and_ignores_ccd():
    """Why the spheres are maximal-coordinate bodies: a multibody base (useMaximalCoordinates
    = 0) is clamped at 100 m/s and ignores ccdSweptSphereRadius (at 10x the threshold it went
    through at 100 m/s)."""
    p = pybullet
    cid = p.connect(p.DIRECT)
    try:
        p.setGravity(0, 0, 0, physicsClientId=cid)
        p.setPhysicsEngineParameter(fixedTimeStep=DT, numSubSteps=0, physicsClientId=cid)
        box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[W / 2, 1, 1],
                                     physicsClientId=cid)
        p.createMultiBody(0, box, useMaximalCoordinates=1, physicsClientId=cid)
        ball = p.createCollisionShape(p.GEOM_SPHERE, radius=R, physicsClientId=cid)
        v = speeds([10.0])[0]
        uid = p.createMultiBody(1.0, ball, basePosition=[-(W / 2 + R) - GAP - v * DT, 0, 0],
                                useMaximalCoordinates=0, physicsClientId=cid)
        p.changeDynamics(uid, -1, ccdSweptSphereRadius=R, linearDamping=0.0,
                         angularDamping=0.0, physicsClientId=cid)  # damping 0.04 otherwise
        p.resetBaseVelocity(uid, [v, 0, 0], [0, 0, 0], physicsClientId=cid)
        for _ in range(20):
            p.stepSimulation(physicsClientId=cid)
        x = p.getBasePositionAndOrientation(uid, physicsClientId=cid)[0][0]
        speed = p.getBaseVelocity(uid, physicsClientId=cid)[0][0]
    finally:
        p.disconnect(cid)
    assert speed == 100.0 and x > 0


def test_plates_without_contact_are_refused():
    from refsim.scene import Scene
    from tunnel_scenes import scene
    bare = Scene(parts=scene([1.0])[0].parts, gravity=(0.0, 0.0, 0.0))
    assert "plates without a contact model" in get_engine("pybullet").supports(bare)


def test_oblique_plate_is_oriented_by_its_normal():
    """Plates with normals (0.6, 0, 0.8) and (-0.6, 0, -0.8): a sphere along the normal at 0.3
    bounces straight back (the box frame follows the normal: a turned box would tilt the
    rebound or let it through) and at 0.6 tunnels (the mid-plane along the normal)."""
    for nrm in (np.array([0.6, 0.0, 0.8]), np.array([-0.6, 0.0, -0.8])):
        through, vn, v, _ = run("pybullet", "", [0.3, 0.6], normal=nrm)
        assert through[0] < 0 < through[1]
        # e = 1 (sqrt(1) per shape) and the impulse along the normal: round-off of the
        # rotated contact normal (1e-16) times the speed
        assert abs(vn[0] + speeds([0.3])[0]) < 1e-12
        assert np.linalg.norm(v[0] - vn[0] * nrm) < 1e-12
