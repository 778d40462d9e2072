"""Scenes and reference replicas shared by the engines' pivot tests (MuJoCo, pybullet, pymunk;
tests/conformance/test_conformance_pivots.py and each engine's test_<engine>_pivots.py): one
rigid body on a ball joint, the exact replica of the model's symplectic Euler step about the
pivot, a converged solve of Euler's equations (scipy DOP853, rtol 1e-12) and the compound
pendulum's closed form (w0^2 = 3 g / (2 L), cases/particles/pendulum.py exact_pendulum).

The heavy top: m = 1 kg, I0 = diag(0.2, 0.2, 0.05) kg m^2, pivot 0.5 m below the centre of mass
on the symmetry axis, tilted 0.3 rad, spinning 10 rad/s about its axis: it nutates and precesses.
The rod: length L = 1 m, m = 1 kg, I = m L^2 / 12 across, pivoted at its top end, from rest at
1 rad about +y (its centre starts at -(L/2) (sin theta0, 0, cos theta0)).
Imported by basename (tests/engines/conftest.py puts this directory on the path)."""
import functools

import numpy as np
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from refsim_cases.particles.pendulum import exact_pendulum
from refsim.scene import RigidBodies, Scene
from refsim.scene.pivots import RigidPivots

G = 9.81
EPS = np.finfo(float).eps
L, M, THETA0 = 1.0, 1.0, 1.0  # the rod
W0 = np.sqrt(1.5 * G / L)  # compound pendulum: m g (L/2) / (m L^2/12 + m L^2/4) = 3 g / (2 L)


def rot(q):
    return Rotation.from_quat(np.roll(q, -1)).as_matrix()


def qmul(a, b):
    return np.concatenate([[a[0] * b[0] - a[1:] @ b[1:]],
                           a[0] * b[1:] + b[0] * a[1:] + np.cross(a[1:], b[1:])])


def pivoted(m, inertia, point, q0, w_body0=(0.0, 0.0, 0.0), anchor=(0.0, 0.0, 0.0),
            planar=False):
    """One body pivoted at `anchor` through body point `point`, at rest on it at t = 0."""
    R, anchor, w_body0 = rot(q0), np.asarray(anchor, float), np.asarray(w_body0, float)
    x0 = anchor - R @ point
    rigid = RigidBodies(mass=[m], inertia=[inertia], position=[x0], orientation=[q0],
                        velocity=[np.cross(R @ w_body0, x0 - anchor)],
                        angular_velocity=[R @ w_body0])
    return Scene(parts=(rigid, RigidPivots(body=[0], body_point=[point], anchor=[anchor])), gravity=(0.0, 0.0, -G), planar=planar)


def top(spin=10.0, tilt=0.3, planar=False):
    q0 = np.array([np.cos(tilt / 2), np.sin(tilt / 2), 0.0, 0.0])
    return pivoted(1.0, np.diag([0.2, 0.2, 0.05]), np.array([0.0, 0.0, -0.5]), q0,
                   np.array([0.0, 0.0, spin]), planar=planar)


def asymmetric():
    """A non-diagonal tensor, an off-axis pivot, a skew orientation: every conversion used."""
    axes = Rotation.from_rotvec([0.4, 0.2, -0.9]).as_matrix()
    inertia = axes @ np.diag([0.3, 0.5, 0.7]) @ axes.T
    q0 = np.roll(Rotation.from_rotvec([0.3, -0.5, 0.7]).as_quat(), 1)
    return pivoted(2.0, inertia, np.array([0.1, -0.2, 0.4]), q0, np.array([1.0, -2.0, 3.0]),
                   anchor=(0.3, 0.1, 1.0))


def rod(theta0=THETA0, planar=False):
    """The rod along its body z, pivot at its top end, turned by theta0 about +y: its centre
    starts at -(L/2) (sin theta0, 0, cos theta0), the angle -theta0 from straight down."""
    q0 = np.array([np.cos(theta0 / 2), 0.0, np.sin(theta0 / 2), 0.0])
    inertia = np.diag([M * L * L / 12, M * L * L / 12, 1e-4 * M * L * L])
    return pivoted(M, inertia, np.array([0.0, 0.0, L / 2]), q0, planar=planar)


def rod_exact_angle(t, theta0=THETA0):
    """The closed-form angle of the rod's centre from straight down at time t (the rod swings
    from -x: angle -theta0 at t = 0)."""
    return -exact_pendulum(theta0, W0, t)[0]


def angle_of_centre(obs):
    return np.arctan2(obs["x"][0][0], -obs["x"][0][2])


def pivot_terms(scene):
    """(m, I_p about the pivot (body frame), body point p, gravity)."""
    r, pv = scene.part(RigidBodies), scene.part(RigidPivots)
    m, p = r.mass[0], pv.body_point[0]
    return m, r.inertia[0] + m * (p @ p * np.eye(3) - np.outer(p, p)), p, \
        np.asarray(scene.gravity)


def body_rate(scene, q, w_body):
    """Euler's equations about the pivot, body frame: I_p w' = tau - w x I_p w, with gravity's
    torque tau = (-p) x m R^T g (the centre of mass sits at -p from the pivot)."""
    m, inertia_p, p, g = pivot_terms(scene)
    tau = np.cross(-p, m * rot(q).T @ g)
    return np.linalg.solve(inertia_p, tau - np.cross(w_body, inertia_p @ w_body))


def reference(scene, t):
    """DOP853 (rtol 1e-12) on (q, w_body): q' = q (x) (0, w_body) / 2."""
    def rhs(_, y):
        return np.concatenate([0.5 * qmul(y[:4], np.concatenate([[0.0], y[4:]])),
                               body_rate(scene, y[:4], y[4:])])
    q0 = scene.part(RigidBodies).orientation[0]
    y0 = np.concatenate([q0, rot(q0).T @ scene.part(RigidBodies).angular_velocity[0]])
    y = solve_ivp(rhs, (0.0, t), y0, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
    q = y[:4] / np.linalg.norm(y[:4])
    return {"q": q, "w": rot(q) @ y[4:]}


@functools.lru_cache(maxsize=None)
def top_reference(t):
    """`reference(top(), t)`, solved once per process (read, never changed)."""
    return reference(top(), t)


def replica(scene, h, steps):
    """The model's symplectic Euler on the pivot: w_body += h rate(q_k, w_k), then
    q <- normalise(q (x) exp(h w_body / 2)) (body-frame rate on the right)."""
    q = scene.part(RigidBodies).orientation[0].copy()
    wb = rot(q).T @ scene.part(RigidBodies).angular_velocity[0]
    for _ in range(steps):
        wb = wb + h * body_rate(scene, q, wb)
        half = 0.5 * h * np.linalg.norm(wb)
        q = qmul(q, np.concatenate([[np.cos(half)], np.sin(half) * wb / np.linalg.norm(wb)]))
        q /= np.linalg.norm(q)
    return q, rot(q) @ wb


def run(engine, scene, h, integrator, t):
    sim = engine.build(scene, h, integrator)
    sim.step(round(t / h))
    assert sim.failure is None
    return sim.observe()
