"""pybullet's pivoted rigid bodies (adapters/pybullet_engine/groups/pivots.py): a fixed-base
multibody with one JOINT_SPHERICAL link, against an exact replica of the model's symplectic
Euler step about the pivot, a converged solve of Euler's equations (scipy DOP853, rtol 1e-12)
for the heavy top, and the compound pendulum's closed form (w0^2 = 3 g / (2 L),
cases/particles/pendulum.py exact_pendulum).

The heavy top: m = 1 kg, I0 = diag(0.2, 0.2, 0.05) kg m^2, pivot 0.5 m below the centre of mass
on the symmetry axis, tilted 0.3 rad, spinning 10 rad/s about its axis.
pybullet is imported on purpose: CI must have every engine (fail, never skip).
"""
import json

import numpy as np
import pybullet  # noqa: F401  (fail, never skip, without the engine)
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from refsim_cases.particles.pendulum import exact_pendulum
from refsim.engine import jsonable
from refsim.observation import check_observation
from refsim.registry import get_engine
from refsim.scene import RigidBodies, Scene
from refsim.scene.pivots import RigidPivots

ENGINE = get_engine("pybullet")
SE = "symplectic_euler"
G = 9.81
EPS = np.finfo(float).eps


def _rot(q):
    return Rotation.from_quat(np.roll(q, -1)).as_matrix()


def _qmul(a, b):
    return np.concatenate([[a[0] * b[0] - a[1:] @ b[1:]],
                           a[0] * b[1:] + b[0] * a[1:] + np.cross(a[1:], b[1:])])


def _pivoted(m, inertia, point, q0, w_body0, anchor=(0.0, 0.0, 0.0)):
    """One body pivoted at `anchor` through body point `point`, at rest on it at t = 0."""
    R, anchor = _rot(q0), np.asarray(anchor, float)
    x0 = anchor - R @ point
    rigid = RigidBodies(mass=[m], inertia=[inertia], position=[x0], orientation=[q0],
                        velocity=[np.cross(R @ w_body0, x0 - anchor)],
                        angular_velocity=[R @ w_body0])
    return Scene(rigid=rigid, gravity=(0.0, 0.0, -G),
                 extra=(RigidPivots(body=[0], body_point=[point], anchor=[anchor]),))


def _top(spin=10.0, tilt=0.3):
    q0 = np.array([np.cos(tilt / 2), np.sin(tilt / 2), 0.0, 0.0])
    return _pivoted(1.0, np.diag([0.2, 0.2, 0.05]), np.array([0.0, 0.0, -0.5]), q0,
                    np.array([0.0, 0.0, spin]))


def _asymmetric():
    """A non-diagonal tensor, an off-axis pivot, a skew orientation: every conversion used."""
    axes = Rotation.from_rotvec([0.4, 0.2, -0.9]).as_matrix()
    inertia = axes @ np.diag([0.3, 0.5, 0.7]) @ axes.T
    q0 = np.roll(Rotation.from_rotvec([0.3, -0.5, 0.7]).as_quat(), 1)
    return _pivoted(2.0, inertia, np.array([0.1, -0.2, 0.4]), q0, np.array([1.0, -2.0, 3.0]),
                    anchor=(0.3, 0.1, 1.0))


def _pivot_terms(scene):
    """(m, I_p about the pivot (body frame), body point p, gravity)."""
    r, pv = scene.rigid, scene.extra[0]
    m, p = r.mass[0], pv.body_point[0]
    return m, r.inertia[0] + m * (p @ p * np.eye(3) - np.outer(p, p)), p, \
        np.asarray(scene.gravity)


def _body_rate(scene, q, w_body):
    """Euler's equations about the pivot, body frame: I_p w' = tau - w x I_p w, with gravity's
    torque tau = (-p) x m R^T g (the centre of mass sits at -p from the pivot)."""
    m, inertia_p, p, g = _pivot_terms(scene)
    tau = np.cross(-p, m * _rot(q).T @ g)
    return np.linalg.solve(inertia_p, tau - np.cross(w_body, inertia_p @ w_body))


def _reference(scene, t):
    """DOP853 (rtol 1e-12) on (q, w_body): q' = q (x) (0, w_body) / 2."""
    def rhs(_, y):
        return np.concatenate([0.5 * _qmul(y[:4], np.concatenate([[0.0], y[4:]])),
                               _body_rate(scene, y[:4], y[4:])])
    q0 = scene.rigid.orientation[0]
    y0 = np.concatenate([q0, _rot(q0).T @ scene.rigid.angular_velocity[0]])
    y = solve_ivp(rhs, (0.0, t), y0, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
    q = y[:4] / np.linalg.norm(y[:4])
    return {"q": q, "w": _rot(q) @ y[4:]}


def _replica(scene, h, steps):
    """The model's symplectic Euler on the pivot: w_body += h rate(q_k, w_k), then
    q <- normalise(q (x) exp(h w_body / 2)) (body-frame rate on the right)."""
    q = scene.rigid.orientation[0].copy()
    wb = _rot(q).T @ scene.rigid.angular_velocity[0]
    for _ in range(steps):
        wb = wb + h * _body_rate(scene, q, wb)
        half = 0.5 * h * np.linalg.norm(wb)
        q = _qmul(q, np.concatenate([[np.cos(half)], np.sin(half) * wb / np.linalg.norm(wb)]))
        q /= np.linalg.norm(q)
    return q, _rot(q) @ wb


def _run(scene, h, t):
    sim = ENGINE.build(scene, h, SE)
    sim.step(round(t / h))
    assert sim.failure is None
    return sim.observe()


def test_group_claims_pivoted_scenes_and_reports_settings():
    scene = _asymmetric()
    assert ENGINE.group_for(scene).name == "pivots"
    sim = ENGINE.build(scene, 1e-3, SE)
    settings = sim.settings()
    json.dumps(jsonable(settings))
    assert settings["integrator"]["name"] == SE and settings["integrator"]["order"] == 1
    assert settings["fixedTimeStep"] == 1e-3 and settings["gravity"] == [0.0, 0.0, -G]
    assert settings["linearDamping"] == settings["angularDamping"] == 0.0
    assert settings["jointDamping"] == 0.0 and settings["formulation"] == "multibody"
    for key in ("motor", "maxJointVelocity", "inertia", "joint", "orientation_update"):
        assert key in settings
    obs = sim.observe()
    assert check_observation(obs, scene) == []
    r = scene.rigid
    for name, want in (("x", r.position), ("v", r.velocity), ("q", r.orientation),
                       ("w", r.angular_velocity)):
        np.testing.assert_allclose(obs[name], want, rtol=0, atol=10 * EPS * np.abs(want).max())


def test_step_is_the_models_symplectic_euler_step():
    """500 steps at h = 1e-3 equal the numpy replica (explicit gyroscopic kick, then the
    quaternion by the new body rate) to 1e-11. Reason: each step rounds ~50 flops of values ~3
    (~1e-14 a step); the motion is regular, so errors add at most linearly: 500 x 1e-14 =
    5e-12 < 1e-11. The pivot holds to round-off (generalized coordinate) and the stored joint
    quaternion stays normalised (defect ~ eps)."""
    scene, h, steps = _asymmetric(), 1e-3, 500
    obs = _run(scene, h, h * steps)
    q, w = _replica(scene, h, steps)
    np.testing.assert_allclose(obs["q"][0] * np.sign(obs["q"][0][0] * q[0]), q, rtol=0,
                               atol=1e-11)
    np.testing.assert_allclose(obs["w"][0], w, rtol=0, atol=1e-11)
    assert obs["pivot_gap"][0] < 100 * EPS and abs(obs["orientation_defect"][0]) < 10 * EPS


def test_heavy_top_converges_to_the_solve_at_order_one():
    """World w at t = 1 s against DOP853, h = 2, 1, 0.5 ms: each halving shows order 1 within
    0.15 (asymptotic range, h |w| <= 0.02: relative corrections of a few per cent; measured
    1.006 and 1.003)."""
    scene, t = _top(), 1.0
    ref = _reference(scene, t)
    errors = [np.abs(_run(scene, h, t)["w"][0] - ref["w"]).max() for h in (2e-3, 1e-3, 5e-4)]
    orders = np.log2(np.array(errors[:-1]) / errors[1:])
    assert np.all(np.abs(orders - 1.0) < 0.15), (errors, orders)


def test_compound_pendulum_converges_to_the_closed_form():
    """A rod (I = m L^2 / 12 across, pivot at one end) from rest at 1 rad, 2 s: its angle
    converges to the closed form with w0^2 = 3 g / (2 L) at order 1 within 0.15 (measured
    1.002, 1.001)."""
    L, m, theta0, t = 1.0, 1.0, 1.0, 2.0
    q0 = np.array([np.cos(theta0 / 2), 0.0, np.sin(theta0 / 2), 0.0])
    scene = _pivoted(m, np.diag([m * L * L / 12, m * L * L / 12, 1e-4 * m * L * L]),
                     np.array([0.0, 0.0, L / 2]), q0, np.zeros(3))
    exact = -exact_pendulum(theta0, np.sqrt(1.5 * G / L), t)[0]
    errors = []
    for h in (2e-3, 1e-3, 5e-4):
        x = _run(scene, h, t)["x"][0]
        errors.append(abs(np.arctan2(x[0], -x[2]) - exact))
    assert np.all(np.abs(np.log2(np.array(errors[:-1]) / errors[1:]) - 1) < 0.15), errors


def test_unpivoted_bodies_are_refused():
    flat = _top().rigid
    two = RigidBodies(mass=[1.0, 1.0], inertia=[flat.inertia[0]] * 2,
                      position=[flat.position[0], [5.0, 0.0, 0.0]],
                      orientation=[flat.orientation[0]] * 2)
    scene = Scene(rigid=two, gravity=(0.0, 0.0, -G), extra=_top().extra)
    assert "must have a pivot" in ENGINE.supports(scene, SE)
