"""MuJoCo against thin plates (issue 28 tunnelling; adapters/mujoco_engine/plates.py): where its
discrete soft contact lets a small fast sphere through, and what speculative contacts (its
continuous detection) stop. Scenes from tests/engines/common/tunnel_scenes.py: each sphere's
previous step ends 1 um before the entry face, speeds as ratios of (w + 2r) / dt; r = 5 cm,
w = 2 cm, dt = 1 ms unless stated. Measured on mujoco 4.0.0.
"""
import math

import mujoco  # noqa: F401  (fail, never skip, without the engine)
import numpy as np
from tunnel_scenes import DT, GAP, R, W, build, run, scene, speeds

from refsim.engine import ContactInfo
from refsim.registry import get_engine
from refsim.scene import Scene
from adapters.mujoco_engine.contact_params import CONTACT_STEPS


def _grid(lo, hi, step):
    return np.round(np.arange(lo, hi + step / 2, step), 6)


def test_discrete_tunnels_where_the_soft_contact_sinks_past_the_mid_plane():
    """The soft contact (K = (pi / (N dt))^2) lets a sphere sink ~ v N dt / pi; past the
    mid-plane the sphere-box test takes the far face: it tunnels from v dt ~ (pi / 2N)(w + 2r),
    ratio pi / 20 = 0.157 at N = 10 (e = 1, undamped), far below the geometric 1 and the
    mid-plane rule's 1/2. Measured: every ratio from 0.1555 up tunnels, every one below
    bounces (a 0.0005 grid)."""
    ratios = _grid(0.150, 0.160, 0.0005)
    through, *_ = run("mujoco", "", ratios)
    tunnelled = ratios[through > 0]
    assert tunnelled.min() == 0.1555 and np.all(ratios[ratios >= 0.1555] == tunnelled)
    # the continuous-time sink estimate ignores the step (detection at step ends, the spring
    # integrated by semi-implicit Euler): 0.0016 below it here
    assert abs(0.1555 - math.pi / (2 * CONTACT_STEPS)) < 0.005
    # far above, every sphere goes through
    far, *_ = run("mujoco", "", [0.3, 0.5, 0.99, 1.01, 2.0, 100.0])
    assert np.all(far > 0)


def test_discrete_threshold_rises_with_damping():
    """A damped contact sinks less: e = 0.5 tunnels from 0.2125 (0.0025 grid); e = 0 (the
    damper stops the sphere at once) follows the mid-plane rule, 1/2 + gap / (w + 2r)."""
    ratios = _grid(0.10, 0.60, 0.0025)
    half, *_ = run("mujoco", "", ratios, e=0.5)
    assert ratios[half > 0].min() == 0.2125 and np.all(half[ratios >= 0.2125] > 0)
    rule = 0.5 + GAP / (W + 2 * R)
    near = np.array([rule - 2e-4, rule + 2e-4])  # 2.4e-5 m of travel either side
    inelastic, *_ = run("mujoco", "", near, e=0.0)
    assert inelastic[0] < 0 < inelastic[1]


def test_speculative_stops_every_sphere_up_to_100x():
    """Speculative contacts (Euler and the implicit integrators): no sphere from 0.05 to 100
    times (w + 2r) / dt gets through; the discrete formulation lets 57 of the same 60
    through (all from 0.2)."""
    ratios = np.concatenate([np.linspace(0.05, 1.0, 20), np.geomspace(1.0, 100.0, 40)])
    for integrator in ("symplectic_euler", "implicit", "implicitfast"):
        through, *_ = run("mujoco", "speculative", ratios, integrator=integrator)
        assert np.all(through < 0), integrator
    discrete, *_ = run("mujoco", "", ratios)
    assert np.sum(discrete > 0) == 57


def test_speculative_fails_where_the_sink_comes_before_its_gate():
    """Speculative contacts engage only when a step moves the sphere more than min(r, w/2);
    slower spheres meet the discrete soft contact. With w = 2r = 10 cm the gate is r (ratio
    0.25) and the sink threshold 0.1555: measured, exactly the spheres in between tunnel."""
    ratios = _grid(0.10, 0.60, 0.0025)
    through, *_ = run("mujoco", "speculative", ratios, w=0.1)
    tunnelled = ratios[through > 0]
    assert tunnelled.min() == 0.1575 and tunnelled.max() == 0.2475
    assert len(tunnelled) == 37  # contiguous: every grid ratio from 0.1575 to 0.2475


def test_speculative_fails_under_rk4():
    """RK4 (four stages, contacts re-detected at each) defeats the speculative distance, which
    assumes one Euler step: from 0.3 times (w + 2r) / dt the spheres go through."""
    ratios = np.array([0.05, 0.1, 0.2, 0.3, 0.5, 1.0, 2.0, 10.0, 100.0])
    sim, lanes, n = build("mujoco", "speculative", ratios, integrator="rk4")
    sim.step(20)
    through = (sim.observe()["x"] - lanes) @ n
    settings = sim.settings()
    sim.close()
    assert list(through > 0) == [False] * 3 + [True] * 6
    assert "measured failing" in settings["speculative_rk4"]


def test_speculative_rebound_is_the_landing_speed_not_the_impact_speed():
    """A speculative hit lands the sphere on the surface: its approach speed becomes the gap
    over dt, and it rebounds at about e times that, whatever its impact speed (here e = 1,
    gap 3 mm, 1 ms: 2.94 m/s back for impacts at 24 to 12000 m/s)."""
    ratios = np.array([0.2, 0.5, 1.0, 10.0, 100.0])
    gap = 3e-3
    _, vn, *_ = run("mujoco", "speculative", ratios, gap=gap, steps=60)
    assert np.all(vn < 0)
    # identical outcomes: the impact speed no longer enters (measured equal to 1e-12)
    assert np.ptp(vn) < 1e-9 * abs(vn[0])
    # the soft contact's own bounce of the landing speed (calibrated e = 1 to within its
    # restitution residual, ~2 % at this onset): 0.98
    assert 0.95 * gap / DT < -vn[0] < gap / DT


def test_settings_declare_detection_side_and_no_clamp():
    eng = get_engine("mujoco")
    for form, detection in (("", "discrete"), ("speculative", "continuous")):
        sim, *_ = build("mujoco", form, [1.0])
        s = sim.settings()
        sim.close()
        assert ContactInfo.of(s).detection == detection and s["plate_side"] == "nearest"
        assert s["engine_variant"] == (form or "default")
    assert eng.formulations(scene([1.0])[0]) == ("", "speculative")
    # no speed clamp: a sphere at 100x (12000 m/s) flies through with its speed bit for bit
    through, vn, v, _ = run("mujoco", "", [100.0])
    assert through[0] > 0 and vn[0] == speeds([100.0])[0]


def test_oblique_plate_is_oriented_by_its_normal():
    """A plate with normal (0.6, 0, 0.8): a slow sphere along the normal comes straight back
    (the box's frame follows the normal: a tilted box would turn the velocity)."""
    nrm = np.array([0.6, 0.0, 0.8])
    _, vn, v, settings = run("mujoco", "", [0.05], normal=nrm, steps=40)
    # the calibrated e = 1 to within its stated residual
    residual = settings["restitution_mapping"]["residual_max"]
    assert abs(-vn[0] / speeds([0.05])[0] - 1) <= residual
    tangential = v[0] - vn[0] * nrm
    assert np.linalg.norm(tangential) < 1e-9 * abs(vn[0])  # round-off of the rotated frame


def test_plates_without_contact_are_refused():
    """(The particles group claims a scene without contacts or walls first: its parts check
    gives the sentence.)"""
    bare = Scene(parts=scene([1.0])[0].parts, gravity=(0.0, 0.0, 0.0))
    assert get_engine("mujoco").supports(bare, "rk4") == "mujoco does not simulate plates"
