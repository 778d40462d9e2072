"""MuJoCo's rigid group (mujoco 4.0.0): free-jointed bodies with full inertia tensors.

Checked: the scene maps onto MuJoCo exactly (initial state, full tensor, world w <-> body-frame
qvel), MuJoCo's Euler IS the model's symplectic Euler with the exponential-map orientation step
(to round-off), body w of the torque-free asymmetric top against a DOP853 solve of Euler's
equations with measured orders, the drift of |L| and E against its first-order rate (Euler
gains, implicit and implicitfast lose: identical on free bodies since mujoco 3.11), RK4 keeps
both, free fall, the normalised quaternion, divergence and refusals.

mujoco is imported at module level on purpose: a missing engine fails here, never skips.
"""
from __future__ import annotations

import json
import math

import mujoco  # noqa: F401  (a missing engine fails here)
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from refsim_adapters.mujoco_engine.spheres import rotate
from refsim.observation import check_observation
from refsim.registry import get_engine
from refsim.scene import RigidBodies, Scene

ENGINE = get_engine("mujoco")
EPS = np.finfo(float).eps
MJ_MINVAL = 1e-15  # mujoco's mjMINVAL: mju_normalize4 leaves |q| alone within it of 1
MOMENTS = np.array([1.0, 2.0, 3.0])  # I1 < I2 < I3: the intermediate axis is unstable
Q0 = np.array([0.8, 0.2, -0.4, 0.4]) / np.linalg.norm([0.8, 0.2, -0.4, 0.4])
W_BODY0 = np.array([0.1, 2.0, 0.05])  # near the intermediate axis: one flip in 10 s
FULL_INERTIA = np.array([[1.2, 0.1, 0.05], [0.1, 2.0, -0.2], [0.05, -0.2, 2.6]])


def _conj(q):
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def _qmul(a, b):
    """Quaternion products of (n, 4) arrays (w, x, y, z)."""
    w1, v1, w2, v2 = a[:, :1], a[:, 1:], b[:, :1], b[:, 1:]
    return np.hstack([w1 * w2 - np.sum(v1 * v2, axis=1, keepdims=True),
                      w1 * v2 + w2 * v1 + np.cross(v1, v2)])


def _top_scene(inertia=None, w_body=W_BODY0, gravity=(0.0, 0.0, 0.0), velocity=(0, 0, 0)):
    inertia = np.diag(MOMENTS) if inertia is None else inertia
    w_world = rotate(Q0[None], np.asarray(w_body, float)[None])
    return Scene(parts=RigidBodies(mass=[1.5], inertia=[inertia], position=[[0.3, -0.2, 1.0]],
                                   orientation=[Q0], velocity=[velocity],
                                   angular_velocity=w_world), gravity=gravity)


def _run(scene, integrator, dt, t_end):
    sim = ENGINE.build(scene, dt, integrator)
    sim.step(round(t_end / dt))
    assert sim.failure is None, sim.failure
    return sim.observe()


def _body_w(obs):
    return rotate(_conj(obs["q"]), obs["w"])


def _euler_equations(t, w):
    """Torque-free Euler equations in the principal body frame: I w' = (I w) x w."""
    return np.cross(MOMENTS * w, w) / MOMENTS


def _dop853(t_end, dense=False):
    """Reference: DOP853 at rtol 1e-12 (the brief's converged solve)."""
    return solve_ivp(_euler_equations, (0.0, t_end), W_BODY0, method="DOP853", rtol=1e-12,
                     atol=1e-14, dense_output=dense)


# ---------------------------------------------------------------------------------------------
# the group, the mapping, settings
# ---------------------------------------------------------------------------------------------
def test_group_claims_rigid_scenes_with_its_integrators():
    scene = _top_scene(gravity=(0, 0, -9.81))
    group = ENGINE.group_for(scene)
    assert group is not None and group.name == "rigid"
    assert ENGINE.formulations(scene) == ("",)
    for integrator in ("symplectic_euler", "rk4", "implicit", "implicitfast"):
        assert ENGINE.supports(scene, integrator) is None
    assert ENGINE.supports(scene, "discrete") == "mujoco offers no integrator 'discrete'"


def test_refusals_name_their_reason():
    flat = np.diag([1.0, 1.0, 2.5])  # A + B < C: no physical body has it
    assert "A + B < C" in ENGINE.supports(_top_scene(inertia=flat), "rk4")
    with pytest.raises(ValueError, match="A \\+ B < C"):
        ENGINE.build(_top_scene(inertia=flat), 1e-3, "rk4")
    rigid = _top_scene().part(RigidBodies)
    dragged = Scene(parts=rigid, linear_drag=0.1)
    assert ENGINE.supports(dragged, "rk4") == "mujoco does not simulate drag"


@pytest.mark.parametrize("inertia", [np.diag(MOMENTS), FULL_INERTIA], ids=["diag", "full"])
def test_initial_observation_is_the_scene(inertia):
    """x, v, q as given; w back from the body frame within a rotation's round-off (two
    rotations by a unit quaternion, each a few eps of |w|)."""
    scene = _top_scene(inertia=inertia, velocity=(1.0, -2.0, 0.5))
    sim = ENGINE.build(scene, 1e-3, "rk4")
    obs = sim.observe()
    assert check_observation(obs, scene) == []
    r = scene.part(RigidBodies)
    assert np.array_equal(obs["x"], r.position) and np.array_equal(obs["v"], r.velocity)
    assert np.array_equal(obs["q"], r.orientation)
    assert np.abs(obs["w"] - r.angular_velocity).max() <= 8 * EPS * np.abs(W_BODY0).max()
    assert abs(obs["orientation_defect"][0]) <= 4 * EPS


def test_settings_are_json_and_name_the_facts():
    settings = ENGINE.build(_top_scene(), 1e-3, "implicitfast").settings()
    json.dumps(settings)
    assert settings["integrator"]["name"] == "implicitfast"
    assert settings["integrator"]["order"] == 1 and settings["timestep"] == 1e-3
    for key in ("quaternion", "angular_velocity_frame", "inertia", "gyroscopic", "damping",
                "velocity_limits", "autoreset", "contacts", "energy_flag"):
        assert key in settings


# ---------------------------------------------------------------------------------------------
# MuJoCo's Euler = the model's symplectic Euler with the exponential-map step
# ---------------------------------------------------------------------------------------------
def _model_symplectic_euler(scene, dt, steps):
    """The brief's equations, world frame, vectorised over bodies: w += h I_w^-1 (tau - w x
    I_w w) with I_w = R I0 R^T at q_k; v += h g; x += h v; q <- exp(h w / 2) (x) q."""
    r = scene.part(RigidBodies)
    x, v, q, w = (np.array(a, float) for a in (r.position, r.velocity, r.orientation,
                                               r.angular_velocity))
    for _ in range(steps):
        rot = np.stack([rotate(q, e) for e in np.eye(3)[:, None, :].repeat(len(q), 1)], -1)
        inertia_w = rot @ r.inertia @ rot.transpose(0, 2, 1)
        lw = np.einsum("nij,nj->ni", inertia_w, w)
        w = w + dt * np.linalg.solve(inertia_w, -np.cross(w, lw)[..., None])[..., 0]
        v = v + dt * np.asarray(scene.gravity)
        x = x + dt * v
        half = 0.5 * dt * w
        angle = np.linalg.norm(half, axis=1, keepdims=True)
        exp = np.hstack([np.cos(angle), np.sinc(angle / np.pi) * half])
        q = _qmul(exp, q)
    return x, v, q, w


@pytest.mark.parametrize("inertia", [np.diag(MOMENTS), FULL_INERTIA], ids=["diag", "full"])
def test_euler_is_the_models_symplectic_euler_with_exp_map(inertia):
    """Same equations, different round-off (body vs world frame): 200 steps agree to 1e-12
    of |w| (200 steps x a few eps each, amplified at most e^(lambda t) with the separatrix
    growth rate lambda <= |w| = 2 /s over t = 0.2 s: 1.5x)."""
    scene = _top_scene(inertia=inertia, gravity=(0.0, 0.0, -9.81), velocity=(1.0, 0, 2.0))
    obs = _run(scene, "symplectic_euler", 1e-3, 0.2)
    x, v, q, w = _model_symplectic_euler(scene, 1e-3, 200)
    assert np.abs(obs["w"] - w).max() <= 1e-12 * np.abs(W_BODY0).max()
    assert np.abs(obs["q"] - q).max() <= 1e-12
    assert np.abs(obs["x"] - x).max() <= 1e-12 and np.abs(obs["v"] - v).max() <= 1e-12


# ---------------------------------------------------------------------------------------------
# torque-free asymmetric top: body w against DOP853, orders
# ---------------------------------------------------------------------------------------------
ORDER_RUNS = {  # integrator: (dts halving, nominal order); RK4 steps are 10x larger so that
    # its error stays far above round-off (1e-12 at dt = 5e-3 over 3 s)
    "rk4": ((4e-2, 2e-2, 1e-2, 5e-3), 4),
    "symplectic_euler": ((4e-3, 2e-3, 1e-3), 1),
    "implicit": ((4e-3, 2e-3, 1e-3), 1),
    "implicitfast": ((4e-3, 2e-3, 1e-3), 1),
}


@pytest.mark.parametrize("integrator", list(ORDER_RUNS))
def test_top_body_w_converges_at_the_nominal_order(integrator):
    """Error of body w at t = 3 s (the first flip under way) against DOP853; the observed
    order log2(e(2h)/e(h)) within 0.1 of nominal: the next term of the error expansion is
    one power of h smaller, i.e. a relative 2^-1 .. 2^-2 change per halving at these h|w| of
    1e-2 .. 8e-2 -> an order shift below 0.1 (measured 3.97-3.99 and 0.995-1.005)."""
    dts, nominal = ORDER_RUNS[integrator]
    reference = _dop853(3.0).y[:, -1]
    errors = [np.abs(_body_w(_run(_top_scene(), integrator, dt, 3.0))[0] - reference).max()
              for dt in dts]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(orders - nominal) < 0.1), (errors, orders)


# ---------------------------------------------------------------------------------------------
# conservation: |L| and E drift per integrator
# ---------------------------------------------------------------------------------------------
def _drift_rates(t_end):
    """First-order growth rates per unit h of ln|L| and ln E for explicit Euler on Euler's
    equations: one kick L_b += h L_b x w adds h^2 |L_b x w|^2 to |L|^2 and h^2/2 (L_b x w).
    I^-1 (L_b x w) to E, exactly; summed over t/h steps along the exact trajectory."""
    sol = _dop853(t_end, dense=True)
    t = np.linspace(0.0, t_end, 20001)
    w = sol.sol(t).T
    lb = MOMENTS * w
    kick = np.cross(lb, w)
    rate_l = 0.5 * np.trapezoid(np.sum(kick ** 2, 1) / np.sum(lb ** 2, 1), t)
    rate_e = 0.5 * np.trapezoid(np.sum(kick ** 2 / MOMENTS, 1) / (0.5 * np.sum(w * lb, 1)), t)
    return rate_l, rate_e


def _l_and_e(obs):
    wb = _body_w(obs)[0]
    return np.linalg.norm(MOMENTS * wb), 0.5 * wb @ (MOMENTS * wb)


@pytest.mark.parametrize("integrator,sign", [("symplectic_euler", +1), ("implicit", -1),
                                             ("implicitfast", -1)])
def test_first_order_drift_of_l_and_e(integrator, sign):
    """Over 10 s at dt = 1e-3 (one flip): Euler's explicit gyroscopic kick raises |L| and E
    at the rates of `_drift_rates`; implicit and implicitfast (the gyroscopic derivative
    implicit: linearised backward Euler, which removes the same h^2 term per step) lower them
    at the same rate. Neglected terms are O(h |w|) relative (the next power of h per step,
    and the O(drift) shift of the trajectory the rate is summed along): 5 h |w|max = 1e-2."""
    dt, t_end = 1e-3, 10.0
    rate_l, rate_e = _drift_rates(t_end)
    l1, e1 = _l_and_e(_run(_top_scene(), integrator, dt, t_end))
    l0, e0 = np.linalg.norm(MOMENTS * W_BODY0), 0.5 * W_BODY0 @ (MOMENTS * W_BODY0)
    tol = 5 * dt * np.linalg.norm(W_BODY0)
    assert math.log(l1 / l0) == pytest.approx(sign * dt * rate_l, rel=tol)
    assert math.log(e1 / e0) == pytest.approx(sign * dt * rate_e, rel=tol)


def test_implicitfast_is_implicit_on_free_bodies():
    """mujoco >= 3.11 applies the gyroscopic derivative of a standalone free body in
    implicitfast too (changelog 3.11.0, a local solve of the body's block instead of the
    full RNE derivative): the same step up to round-off. 200 steps of a few eps each, growth
    at most e^(|w| t) = e^4 along the separatrix: 1e-12 of |w|."""
    a = _run(_top_scene(inertia=FULL_INERTIA), "implicit", 1e-2, 2.0)
    b = _run(_top_scene(inertia=FULL_INERTIA), "implicitfast", 1e-2, 2.0)
    euler = _run(_top_scene(inertia=FULL_INERTIA), "symplectic_euler", 1e-2, 2.0)
    scale = np.abs(W_BODY0).max()
    assert np.abs(a["w"] - b["w"]).max() <= 1e-12 * scale
    assert np.abs(a["q"] - b["q"]).max() <= 1e-12
    assert np.abs(a["w"] - euler["w"]).max() > 1e-4 * scale  # and it is not Euler's step


def test_rk4_conserves_world_l_and_e():
    """RK4's drift is its truncation error: local (h|w|)^5 / 5! relative per step, summed
    over t/h steps: (h|w|)^4 |w| t / 120 = 2.7e-12 at h = 1e-3, |w| = 2, t = 10 s (full
    tensor, world L = R I0 R^T w). Allowed 1e-10: a 40x margin on the unknown constant."""
    scene = _top_scene(inertia=FULL_INERTIA)
    first = ENGINE.build(scene, 1e-3, "rk4")

    def world_l_and_e(obs):
        rot = np.stack([rotate(obs["q"], e[None])[0] for e in np.eye(3)], -1)
        lw = rot @ FULL_INERTIA @ rot.T @ obs["w"][0]
        return lw, 0.5 * obs["w"][0] @ lw

    l0, e0 = world_l_and_e(first.observe())
    l1, e1 = world_l_and_e(_run(scene, "rk4", 1e-3, 10.0))
    assert np.linalg.norm(l1 - l0) / np.linalg.norm(l0) < 1e-10
    assert abs(e1 - e0) / e0 < 1e-10


def test_engine_energy_is_the_scene_energy():
    """MuJoCo's own E (mj_forward, mj_energyPos/Vel) = 1/2 m v^2 + 1/2 w.L - m g.x, to a few
    eps of the energy scale (sums of a handful of products)."""
    scene = _top_scene(inertia=FULL_INERTIA, gravity=(0.0, 0.0, -9.81), velocity=(1.0, 0, 2))
    obs = _run(scene, "symplectic_euler", 1e-3, 0.5)
    rot = np.stack([rotate(obs["q"], e[None])[0] for e in np.eye(3)], -1)
    w = obs["w"][0]
    own = (0.5 * 1.5 * obs["v"][0] @ obs["v"][0] + 0.5 * w @ (rot @ FULL_INERTIA @ rot.T @ w)
           + 1.5 * 9.81 * obs["x"][0, 2])
    assert obs["engine_energy"] == pytest.approx(own, rel=64 * EPS)


# ---------------------------------------------------------------------------------------------
# free fall, quaternion norm, several bodies, divergence
# ---------------------------------------------------------------------------------------------
def test_free_fall_exact():
    """RK4 is exact on a constant acceleration: x = x0 + v0 t + g t^2 / 2; MuJoCo's Euler
    (kick then drift) gives exactly x0 + v0 t + g h^2 k (k + 1) / 2. Both to round-off:
    1000 additions of rounding eps |x| each, |x| <= 10 m: 1000 * 10 * eps = 2.2e-12."""
    g, v0 = np.array([0.0, 0.0, -9.81]), np.array([1.0, 0.5, 3.0])
    scene = _top_scene(inertia=FULL_INERTIA, gravity=g, velocity=v0)
    x0, dt, k = scene.part(RigidBodies).position[0], 1e-3, 1000
    t = k * dt
    rk4 = _run(scene, "rk4", dt, t)
    assert np.abs(rk4["x"][0] - (x0 + v0 * t + 0.5 * g * t * t)).max() <= 2.2e-12
    assert np.abs(rk4["v"][0] - (v0 + g * t)).max() <= 2.2e-12
    euler = _run(scene, "symplectic_euler", dt, t)
    assert np.abs(euler["x"][0] - (x0 + v0 * t + g * dt * dt * k * (k + 1) / 2)).max() <= 2.2e-12


@pytest.mark.parametrize("integrator", list(ORDER_RUNS))
def test_stored_quaternion_stays_normalised(integrator):
    """MuJoCo normalises qpos's quaternion after each position update unless ||q| - 1| <=
    mjMINVAL = 1e-15 (mju_normalize4 skips it then): |q|^2 - 1 stays within 2 mjMINVAL plus
    the rounding of |q|^2 (4 eps), whatever the step; here 1000 steps at h |w| = 2e-2."""
    sim = ENGINE.build(_top_scene(inertia=FULL_INERTIA), 1e-2, integrator)
    worst = 0.0
    for _ in range(10):
        sim.step(100)
        worst = max(worst, abs(sim.observe()["orientation_defect"][0]))
    assert worst <= 2 * MJ_MINVAL + 4 * EPS


def test_bodies_are_independent_and_in_order():
    """Three bodies in one model evolve as each alone, bit for bit (no coupling, no
    reordering): free joints have decoupled 6x6 mass-matrix blocks."""
    ws = np.array([[0.1, 2.0, 0.05], [1.0, -0.5, 0.3], [0.0, 0.2, -3.0]])
    qs = np.array([Q0, [1.0, 0, 0, 0], [0.5, 0.5, -0.5, 0.5]])
    rigid = RigidBodies(mass=[1.5, 2.0, 0.5], inertia=[FULL_INERTIA, np.diag(MOMENTS),
                                                      np.diag([2.0, 2.0, 3.0])],
                        position=[[0, 0, 0], [1, 2, 3], [-1, 0, 5]], orientation=qs,
                        velocity=[[0, 0, 1], [1, 0, 0], [0, 2, 0]], angular_velocity=ws)
    together = _run(Scene(parts=rigid, gravity=(0, 0, -9.81)), "rk4", 1e-2, 1.0)
    for i in range(3):
        single = RigidBodies(mass=rigid.mass[i:i + 1], inertia=rigid.inertia[i:i + 1],
                             position=rigid.position[i:i + 1],
                             orientation=rigid.orientation[i:i + 1],
                             velocity=rigid.velocity[i:i + 1],
                             angular_velocity=rigid.angular_velocity[i:i + 1])
        alone = _run(Scene(parts=single, gravity=(0, 0, -9.81)), "rk4", 1e-2, 1.0)
        # same operations: MuJoCo's code on each free body's own 6x6 block (measured on x86-64)
        assert all(np.array_equal(together[k][i], alone[k][0]) for k in ("x", "v", "q", "w"))


def test_divergence_is_a_failure():
    """A spin far beyond float range (the gyroscopic term overflows to inf) is reported as a
    failure, with auto-reset off: the state is not silently reset."""
    sim = ENGINE.build(_top_scene(w_body=(1e160, 2e160, 3e155)), 1e-3, "symplectic_euler")
    sim.step(10)
    assert sim.failure is not None and "mjWARN_BAD" in sim.failure
