"""pybullet's rigid group (adapters/pybullet_engine/groups/rigid.py): both formulations against
exact discrete replicas of their steps, against a converged solve of Euler's equations (order
1), their angular-momentum and energy drift, free fall, the raised clamp and Bullet's
orientation-step limit.

The top: I0 = Q diag(1, 2, 3) Q^T (a non-diagonal body tensor, so the principal-frame
conversion is exercised), a non-trivial scene orientation, body rate Q (0.05, 2, 0.03) rad/s:
near the intermediate axis, it flips (Dzhanibekov) within the 10 s run.
pybullet is imported on purpose: CI must have every engine (fail, never skip).
"""
import json
import math

import numpy as np
import pybullet  # noqa: F401  (fail, never skip, without the engine)
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from refsim.observation import check_observation
from refsim.registry import get_engine
from refsim.scene import RigidBodies, Scene

ENGINE = get_engine("pybullet")
SE = "symplectic_euler"
FORMS = ("multibody", "maximal")
EPS = np.finfo(float).eps
G = 9.81

Q_INERTIA = Rotation.from_rotvec([0.4, 0.2, -0.9]).as_matrix()
I0 = Q_INERTIA @ np.diag([1.0, 2.0, 3.0]) @ Q_INERTIA.T
Q_SCENE = Rotation.from_rotvec([0.3, -0.5, 0.7])
W_BODY0 = Q_INERTIA @ np.array([0.05, 2.0, 0.03])


def _top(w_body=W_BODY0, inertia=I0, orientation=Q_SCENE, gravity=(0.0, 0.0, 0.0),
         velocity=(0.0, 0.0, 0.0), position=(0.0, 0.0, 0.0)):
    rigid = RigidBodies(mass=[1.5], inertia=[inertia], position=[position],
                        orientation=[np.roll(orientation.as_quat(), 1)], velocity=[velocity],
                        angular_velocity=[orientation.apply(w_body)])
    return Scene(parts=(rigid,), gravity=gravity)


def _rotation(obs):
    return Rotation.from_quat(np.roll(obs["q"][0], -1)).as_matrix()


# -- numpy replicas of the two formulations' steps (world w, scene body frame, full I0) --------
def _skew(a):
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def _explicit_gyro(rot, w, h):
    """The model's symplectic Euler velocity step: w - h I_w^-1 (w x I_w w), I_w at q_k."""
    inertia_w = rot @ I0 @ rot.T
    return w - h * np.linalg.solve(inertia_w, np.cross(w, inertia_w @ w))


def _implicit_body_gyro(rot, w, h):
    """One Newton step, from w' = w, of implicit Euler I0 (w' - w) + h w' x I0 w' = 0 in the
    body frame (Bullet's BT_ENABLE_GYROSCOPIC_FORCE_IMPLICIT_BODY, written from its equation)."""
    wb = rot.T @ w
    residual = h * np.cross(wb, I0 @ wb)
    jacobian = I0 + h * (_skew(wb) @ I0 - _skew(I0 @ wb))
    return rot @ (wb - np.linalg.solve(jacobian, residual))


REPLICA = {"multibody": _explicit_gyro, "maximal": _implicit_body_gyro}


@pytest.mark.parametrize("form", FORMS)
def test_steps_equal_their_exact_replicas(form):
    """1000 steps at h = 1e-2 (through the flip): world w and R equal the replica's (velocity
    step, then R <- exp(h [w_{k+1}]) R) to 1e-9. Reason: each step rounds ~10 flops of size
    |w| ~ 2 (~4e-15); phase errors near the separatrix grow at most linearly over one flip,
    1000 steps x 4e-15 x 100 (separatrix amplification allowance) = 4e-10 < 1e-9; measured
    5e-12 (multibody) and 7e-12 (maximal)."""
    h, steps = 1e-2, 1000
    sim = ENGINE.build(_top(), h, SE, form)
    obs = sim.observe()
    rot, w = _rotation(obs), obs["w"][0].copy()
    worst = 0.0
    for _ in range(steps):
        sim.step(1)
        w = REPLICA[form](rot, w, h)
        rot = Rotation.from_rotvec(h * w).as_matrix() @ rot
        obs = sim.observe()
        worst = max(worst, np.abs(obs["w"][0] - w).max(), np.abs(_rotation(obs) - rot).max())
    sim.close()
    assert worst < 1e-9, worst


def _euler_reference(t_end):
    """Body rate of the torque-free top, DOP853 rtol 1e-12 (its error ~1e-11, far below the
    first-order errors ~1e-2 measured here)."""
    return solve_ivp(lambda t, w: np.linalg.solve(I0, -np.cross(w, I0 @ w)), (0.0, t_end),
                     W_BODY0, method="DOP853", rtol=1e-12, atol=1e-14, dense_output=True)


def _body_rate_error(form, dt, reference, t_end):
    sim = ENGINE.build(_top(), dt, SE, form)
    worst = 0.0
    for _ in range(round(t_end / dt) // 10):
        sim.step(10)
        obs = sim.observe()
        body_w = _rotation(obs).T @ obs["w"][0]
        worst = max(worst, np.abs(body_w - reference.sol(obs["t"])).max())
    sim.close()
    return worst


@pytest.mark.parametrize("form", FORMS)
def test_body_rate_converges_at_first_order(form):
    """Body w (scene body frame) against DOP853 over 10 s, which hold the Dzhanibekov flip
    (the reference's intermediate component changes sign). Both formulations are first-order
    (explicit resp. one-Newton-step implicit Euler): halving dt halves the error, so the
    measured order log2(e(2h)/e(h)) lies within 1 +- 0.1 (the O(h) correction to a first-order
    error ratio at h |w| <= 4e-3 is far below 0.1). Measured: 7.2e-3 at dt 1e-3, order 0.999
    (both)."""
    t_end, dt = 10.0, 1e-3
    reference = _euler_reference(t_end)
    middle = Q_INERTIA.T @ reference.sol(np.linspace(0.0, t_end, 2001))
    assert middle[1].min() < 0 < middle[1].max()  # the flip happens in the run
    coarse, fine = (_body_rate_error(form, h, reference, t_end) for h in (2 * dt, dt))
    order = math.log2(coarse / fine)
    assert abs(order - 1.0) < 0.1, (coarse, fine, order)


def _drift(form, dt, t_end=10.0):
    sim = ENGINE.build(_top(), dt, SE, form)
    start = sim.observe()
    sim.step(round(t_end / dt))
    end = sim.observe()
    sim.close()
    momentum0 = start["angular_momentum"][0]
    return (np.linalg.norm(end["angular_momentum"][0] - momentum0) / np.linalg.norm(momentum0),
            np.linalg.norm(end["angular_momentum"][0]) / np.linalg.norm(momentum0) - 1.0,
            end["energy"][0] / start["energy"][0] - 1.0)


@pytest.mark.parametrize("form", FORMS)
def test_drift_sign_and_first_order(form):
    """10 s through the flip at dt 1e-2 and 1e-3: the explicit gyroscopic term (multibody)
    gains |L| and energy, the implicit one (maximal) loses both. The drift is a first-order
    error, O(h): the ratio between the two dts is 10 within 10 % (the O(h) correction at
    h |w| <= 3e-2). Measured |L|: +1.17e-2 / +1.15e-3 (multibody), -1.14e-2 / -1.15e-3
    (maximal); energy about twice that, same signs."""
    coarse, fine = _drift(form, 1e-2), _drift(form, 1e-3)
    sign = 1.0 if form == "multibody" else -1.0
    for rel_coarse, rel_fine in zip(coarse[1:], fine[1:]):  # |L|, energy
        assert sign * rel_coarse > 0 and sign * rel_fine > 0, (coarse, fine)
        assert abs(rel_coarse / rel_fine - 10.0) < 1.0, (coarse, fine)


def test_multibody_growth_is_exact_discrete():
    """World-frame velocity step at fixed R_k, then a rotation about w_{k+1}, which changes
    neither |L| nor w . I_w w: |L_{k+1}|^2 - |L_k|^2 = h^2 |w_k x L_k|^2 and
    E_{k+1} - E_k = h^2/2 (w_k x L_k) . I_w^-1 (w_k x L_k) exactly. Over 1000 steps at
    h = 1e-2 the summed growths (~1.8 and ~0.1) match to 1e-10 relative: round-off of
    |L|^2 ~ 16 and E ~ 4 is ~4e-15 per step, 1000 steps ~4e-12 absolute."""
    h = 1e-2
    sim = ENGINE.build(_top(), h, SE, "multibody")
    obs = sim.observe()
    first = (_squared(obs["angular_momentum"][0]), obs["energy"][0])
    predicted = np.zeros(2)
    for _ in range(1000):
        momentum, w = obs["angular_momentum"][0], obs["w"][0]
        rot = _rotation(obs)
        torque_impulse = h * np.cross(w, momentum)
        predicted += [_squared(torque_impulse), 0.5 * torque_impulse
                      @ np.linalg.solve(rot @ I0 @ rot.T, torque_impulse)]
        sim.step(1)
        obs = sim.observe()
    sim.close()
    growth = np.array([_squared(obs["angular_momentum"][0]), obs["energy"][0]]) - first
    assert np.all(np.abs(growth - predicted) < 1e-10 * predicted), (growth, predicted)


def _squared(vector):
    return float(np.dot(vector, vector))


def test_maximal_momentum_never_grows():
    """Exact implicit Euler gives |L_{k+1}|^2 = L_k . L_{k+1} <= |L_k| |L_{k+1}|; Bullet's one
    Newton step keeps that here: no step raises |L| by more than round-off (|L|^2 ~ 16, so
    64 eps)."""
    h = 1e-2
    sim = ENGINE.build(_top(), h, SE, "maximal")
    sizes = []
    for _ in range(1000):
        sizes.append(_squared(sim.observe()["angular_momentum"][0]))
        sim.step(1)
    sim.close()
    assert np.diff(sizes).max() <= 64 * EPS * max(sizes), np.diff(sizes).max()


@pytest.mark.parametrize("form", FORMS)
def test_free_fall_is_semi_implicit_euler(form):
    """A spinning body thrown under gravity: z_k = z0 + k h vz - k(k+1)/2 h^2 g exactly (the
    error against the continuous solution is -g t h / 2), x advances k h vx, round-off only:
    each step adds ~1 ulp of |z| <= 2 m (4.4e-16), 1000 steps 4.4e-13 < 1e-12 m. The
    multibody's m w x v terms cancel (the spin must not leak into the fall)."""
    h, steps, vz, vx = 1e-3, 1000, 2.0, 0.7
    scene = _top(gravity=(0.0, 0.0, -G), velocity=(vx, 0.0, vz), position=(0.0, 0.0, 1.0))
    sim = ENGINE.build(scene, h, SE, form)
    sim.step(steps)
    obs = sim.observe()
    sim.close()
    k, t = steps, steps * h
    z_exact_discrete = 1.0 + k * h * vz - k * (k + 1) / 2 * h * h * G
    z_continuous = 1.0 + vz * t - 0.5 * G * t * t
    assert abs(obs["x"][0, 2] - z_exact_discrete) < 1e-12
    assert abs((obs["x"][0, 2] - z_continuous) - (-G * t * h / 2)) < 1e-12
    assert abs(obs["x"][0, 0] - k * h * vx) < 1e-12
    assert abs(obs["v"][0, 2] - (vz - k * h * G)) < 1e-12


def test_multibody_angular_speed_clamp_is_raised():
    """The multibody base clamps each velocity component at 100 (rad/s) by default (measured:
    150 became 100 in one step); the group raises it, so 150 rad/s about a principal axis
    stays 150 exactly (a principal-axis spin has no gyroscopic torque)."""
    inertia = np.diag([1.0, 2.0, 3.0])
    sim = ENGINE.build(_top(w_body=(0.0, 0.0, 150.0), inertia=inertia), 1e-3, SE, "multibody")
    sim.step(5)
    speed = np.linalg.norm(sim.observe()["w"][0])
    sim.close()
    assert abs(speed - 150.0) < 1e-12 * 150.0


@pytest.mark.parametrize("form", FORMS)
@pytest.mark.parametrize("w_h", [0.5, 0.9])
def test_orientation_step_limit(form, w_h):
    """Bullet's ANGULAR_MOTION_THRESHOLD (reported in settings): below |w| h = pi/4 a
    principal-axis spin turns by |w| h per step; above it by 2 atan(tan(pi/8) |w| h / (pi/4)).
    Exact formulas, round-off only (1e-12 rad)."""
    h = 1e-2
    scene = _top(w_body=(0.0, 0.0, w_h / h), inertia=np.diag([1.0, 2.0, 3.0]),
                 orientation=Rotation.identity())
    sim = ENGINE.build(scene, h, SE, form)
    limit = sim.settings()["orientation_step_limit"]
    sim.step(1)
    angle = Rotation.from_matrix(_rotation(sim.observe())).magnitude()
    sim.close()
    threshold = math.pi / 4
    expected = w_h if w_h <= threshold else 2 * math.atan(math.tan(math.pi / 8) * w_h / threshold)
    assert abs(angle - expected) < 1e-12, (angle, expected)
    assert limit["exceeded_at_start"] == (w_h > threshold)


@pytest.mark.parametrize("form", FORMS)
def test_contract_settings_and_frames(form):
    """The group claims the rigid scene, offers both formulations and symplectic_euler only;
    observations follow the contract and start at the scene's state (q in the scene's body
    frame despite the principal-frame rotation, to 1e-15); every setting is JSON data."""
    scene = _top(gravity=(0.0, 0.0, -G))
    assert ENGINE.group_for(scene).name == "rigid"
    assert ENGINE.formulations(scene) == FORMS
    assert "rk4" in ENGINE.supports(scene, "rk4")
    sim = ENGINE.build(scene, 1e-3, SE, form)
    obs, settings = sim.observe(), sim.settings()
    sim.close()
    assert check_observation(obs, scene) == []
    q0 = scene.part(RigidBodies).orientation[0]
    assert min(np.abs(obs["q"][0] - q0).max(), np.abs(obs["q"][0] + q0).max()) < 1e-15
    assert np.abs(obs["w"][0] - scene.part(RigidBodies).angular_velocity[0]).max() < 1e-14
    assert abs(obs["orientation_defect"][0]) < 4 * EPS
    json.dumps(settings)
    assert settings["formulation"] == form and settings["numSubSteps"] == 0
    assert settings["fixedTimeStep"] == 1e-3 and settings["gravity"] == [0.0, 0.0, -G]
    assert settings["linearDamping"] == settings["angularDamping"] == 0.0
    assert settings["useMaximalCoordinates"] == (form == "maximal")
    assert settings["integrator"]["order"] == 1 and not settings["integrator"]["symplectic"]
    assert np.allclose(settings["principal_moments"], [[1.0, 2.0, 3.0]], rtol=0, atol=1e-14)


@pytest.mark.parametrize("form", FORMS)
def test_bodies_never_collide(form):
    """Two bodies thrown through each other (their collision spheres overlap from step 1):
    the collision filter keeps them free, x_k = x0 + k h v to round-off (1e-12 m: ~1 ulp of
    |x| <= 1 m per step over 500 steps); v stays to round-off (2.3e-13 m/s: the multibody adds
    and removes m w x v each step, ~1 ulp of |w| |v| <= 2 per step over 500 steps)."""
    h, steps = 1e-3, 500
    rigid = RigidBodies(mass=[1.0, 3.0], inertia=[I0, np.diag([2.0, 2.0, 1.0])],
                        position=[[0.0, 0.0, 0.0], [1e-4, 0.0, 0.0]],
                        orientation=[[1.0, 0.0, 0.0, 0.0]] * 2,
                        velocity=[[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]],
                        angular_velocity=[[0.0, 1.0, 0.0], [0.0, 0.0, 2.0]])
    scene = Scene(parts=(rigid,))
    sim = ENGINE.build(scene, h, SE, form)
    sim.step(steps)
    obs = sim.observe()
    sim.close()
    expected = rigid.position + steps * h * rigid.velocity
    assert np.abs(obs["x"] - expected).max() < 1e-12
    assert np.abs(obs["v"] - rigid.velocity).max() < 500 * 2 * EPS
