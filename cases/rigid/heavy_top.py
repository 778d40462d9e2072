"""Heavy symmetric top: a spinning body with its tip fixed at the origin, under gravity -z.

Moments about the centre of mass I1 = I2 != I3 (body axis 3 the symmetry axis); the centre of
mass at distance l along body axis 3 from the tip (the pivot, `RigidPivots`). About the pivot
I1' = I1 + M l^2 (parallel axis), I3' = I3. Released tilted by `tilt` from the vertical (a
rotation about world x), spinning at w3 about its own axis, with no precession.
Sleeping top (docs/models.md#rigid-sleeping-top; Goldstein, Classical Mechanics, sec. 5.7): the
upright top is stable iff I3^2 w3^2 > 4 I1' M g l, i.e. w3 > w3c = 2 sqrt(I1' M g l) / I3
(`sleeping_threshold`);
`spin_ratio` = w3 / w3c. Linearised about the upright, the tilt (complex, x + i y of e3) is a sum
of two circular modes Omega_pm = Omega_c (r +- sqrt(r^2 - 1)), Omega_c = sqrt(M g l / I1'):
released from rest it reaches theta0 r / sqrt(r^2 - 1) for r > 1 and grows like
exp(Omega_c sqrt(1 - r^2) t) for r < 1 (`linear_tilt_ratio`).
Reference: a converged DOP853 solve (rtol 1e-12, atol 1e-14) of Euler's equations about the
pivot in the body frame, I' w_b' + w_b x I' w_b = c x (R^T M g), c = (0, 0, l), with
q' = 1/2 q (x) (0, w_b). Compared observable `e3`: the symmetry axis in the world (unitless,
max |e3 - e3_ref|); also `tilt` (rad, the nutation angle). Conserved: E, L_z (world vertical)
and L_3 = I3 w3 (about the pivot): `momentum_drift` = max(|L_z - L_z0|, |L_3 - L_30|) / (I3 w3)
(the larger of the two relative drifts; `L_z_drift`, `L_3_drift` report each).
`find_threshold` bisects the spin ratio at which an engine's top stays up (tilt below `factor`
times its start over `periods` periods 2 pi / Omega_c).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from refsim.case import ADAPTIVE_REASON, Param, adaptive_rtol
from refsim.expected import discrete_solution
from refsim.scene import RigidBodies, Scene
from refsim.scene.pivots import RigidPivots

from . import RigidCase, quat_multiply, quat_to_matrix, rotation_quaternion
from ._bounds import (KICK_METHODS, KICK_REASON, PRINTED_REASON, chart_error, method_name,
                      mode_error)

REFERENCE_RTOL, REFERENCE_ATOL = 1e-12, 1e-14
EPS = float(np.finfo(float).eps)
SAFETY = 3.0  # the one safety factor of the bound (tolerance)


def _check(p):
    if p["I3"] == p["I1"]:
        raise ValueError(f"heavy_top.I3 must differ from heavy_top.I1 (a symmetric top with a "
                         f"distinct axis), got I1 = I3 = {p['I1']}")


def pivot_moments(p) -> np.ndarray:
    """(I1', I1', I3): principal moments about the tip, I1' = I1 + M l^2."""
    _check(p)
    i1p = p["I1"] + p["mass"] * p["length"] ** 2
    return np.array([i1p, i1p, p["I3"]])


def sleeping_threshold(p) -> float:
    """w3c = 2 sqrt(I1' M g l) / I3 (rad/s): the upright top is stable iff w3 > w3c."""
    i1p = pivot_moments(p)[0]
    return 2.0 * np.sqrt(i1p * p["mass"] * p["g"] * p["length"]) / p["I3"]


def threshold_rate(p) -> float:
    """Omega_c = sqrt(M g l / I1') (rad/s): the two precession modes' common rate at w3c."""
    return float(np.sqrt(p["mass"] * p["g"] * p["length"] / pivot_moments(p)[0]))


def spin(p) -> float:
    return p["spin_ratio"] * sleeping_threshold(p)


def initial_orientation(p) -> np.ndarray:
    return rotation_quaternion(np.array([p["tilt"], 0.0, 0.0]))


def initial_world_omega(p) -> np.ndarray:
    return quat_to_matrix(initial_orientation(p)) @ np.array([0.0, 0.0, spin(p)])


def linear_tilt_ratio(r, omega_c_t) -> np.ndarray:
    """|tilt(t)| / theta0 of the top linearised about the upright, released from rest at
    spin ratio r, at times Omega_c t: |(W+ e^{i W- t} - W- e^{i W+ t}) / (W+ - W-)| with
    W_pm = r +- sqrt(r^2 - 1) (complex for r < 1); r = 1 is its limit |1 - i Omega_c t|."""
    s = np.sqrt(complex(r * r - 1.0))
    tau = np.asarray(omega_c_t, float)
    if abs(s) < 1e-7:
        return np.abs(1.0 - 1j * tau)
    w_plus, w_minus = r + s, r - s
    return np.abs((w_plus * np.exp(1j * w_minus * tau) - w_minus * np.exp(1j * w_plus * tau))
                  / (w_plus - w_minus))


def _key(p):
    return tuple(sorted(p.items()))


@lru_cache(maxsize=16)
def _reference_solution(key):
    p = dict(key)
    inertia = pivot_moments(p)
    arm_weight = p["mass"] * p["g"] * p["length"]

    def rhs(_, state):
        w, q = state[:3], state[3:]
        up = quat_to_matrix(q)[2]  # R^T e_z: the world vertical in the body frame
        torque = arm_weight * np.array([up[1], -up[0], 0.0])  # (0, 0, l) x (-M g up)
        dw = (torque - np.cross(w, inertia * w)) / inertia
        return np.concatenate([dw, 0.5 * quat_multiply(q, np.r_[0.0, w])])

    state0 = np.concatenate([[0.0, 0.0, spin(p)], initial_orientation(p)])
    return solve_ivp(rhs, (0.0, p["duration"]), state0, method="DOP853", rtol=REFERENCE_RTOL,
                     atol=REFERENCE_ATOL, dense_output=True).sol


def reference_state(p, t):
    """(w_body (T, 3), q (T, 4)) of the converged solve at times t."""
    y = _reference_solution(_key(p))(np.asarray(t, float)).T
    return y[:, :3], y[:, 3:]


def axis_observables(p, q, w_body) -> dict:
    """e3 (world symmetry axis), tilt, L_z, L_3 (about the pivot) from q and body w."""
    rotation = quat_to_matrix(q)
    e3 = rotation[..., :, 2]
    momentum = np.einsum("...ij,...j->...i", rotation, pivot_moments(p) * w_body)
    return {"e3": e3, "tilt": np.arctan2(np.hypot(e3[..., 0], e3[..., 1]), e3[..., 2]),
            "L_z": momentum[..., 2], "L_3": p["I3"] * w_body[..., 2]}


def _stays_up(engine, integrator, dt, variant, p, periods, factor) -> bool:
    from refsim_cases.rigid.heavy_top import (
        CASE,  # the case as registered (this module's CASE)
    )
    sim = engine.build(CASE.scene(p), dt, integrator, variant)
    chunk = max(1, round(0.25 / (threshold_rate(p) * dt)))  # a quarter radian of Omega_c
    end = periods * 2.0 * np.pi / threshold_rate(p)
    limit = np.cos(factor * p["tilt"])
    while sim.time() < end and not sim.failure:
        sim.step(chunk)
        q = np.asarray(sim.observe()["q"], float)[0]
        if quat_to_matrix(q)[2, 2] < limit:
            return False
    return sim.failure is None


def find_threshold(engine, integrator, dt, variant="", low=0.8, high=1.2, resolution=1e-3,
                   periods=3.0, factor=10.0, tilt=1e-3):
    """The spin ratio r = w3 / w3c at which the engine's top, released at `tilt`, keeps its
    tilt below `factor` times the start over `periods` periods 2 pi / Omega_c: bisected in
    [low, high] (falls at low, stays up at high, checked) to `resolution`."""
    if not 0.0 < low < high:
        raise ValueError(f"find_threshold needs 0 < low < high, got low = {low}, high = {high}")
    from refsim_cases.rigid.heavy_top import CASE
    base = CASE.variant_params("sleeping_stable", {"tilt": tilt})

    def stays(r):
        p = {**base, "spin_ratio": r, "duration": periods * 2 * np.pi / threshold_rate(base)}
        return _stays_up(engine, integrator, dt, variant, p, periods, factor)

    if stays(low) or not stays(high):
        raise ValueError(f"find_threshold: the top must fall at low = {low} and stay up at "
                         f"high = {high}")
    while high - low > resolution:
        mid = 0.5 * (low + high)
        low, high = (low, mid) if stays(mid) else (mid, high)
    return 0.5 * (low + high)


class HeavyTop(RigidCase):
    name = "heavy_top"
    description = ("heavy symmetric top, tip fixed: precession and nutation against a DOP853 "
                   "solve; sleeping top stable iff I3^2 w3^2 > 4 I1' M g l")
    tags = ("rigid", "rotation", "pivot", "converged")
    observable, units = "e3", "1"
    params = {
        "I1": Param(0.7, 0.0, 1e6, "transverse moment about the centre of mass (kg m^2)",
                    low_inclusive=False),
        "I3": Param(1.0, 0.0, 1e6, "axial moment (kg m^2), != I1", low_inclusive=False),
        "mass": Param(1.25, 0.0, 1e6, "M (kg); not 1, nor l: a dropped M or l in M g l or "
                      "M l^2 fails (I1' = 1.5, M l = 1 kg m)", low_inclusive=False),
        "length": Param(0.8, 0.0, 1e3, "l: tip to centre of mass (m)", low_inclusive=False),
        "g": Param(9.81, 0.0, 1e3, "m/s^2", low_inclusive=False),
        "spin_ratio": Param(2.0, 0.0, 100.0, "w3 / w3c, w3c = 2 sqrt(I1' M g l) / I3",
                            low_inclusive=False),
        "tilt": Param(0.3, 0.0, 1.5, "initial tilt from the vertical (rad)",
                      low_inclusive=False),
        "duration": Param(3.0, 0.0, 1e3, "s", low_inclusive=False),
    }
    variants = {"nutation": {},
                "sleeping_stable": {"spin_ratio": 1.5, "tilt": 1e-3, "duration": 3.0},
                "sleeping_unstable": {"spin_ratio": 0.7, "tilt": 1e-3, "duration": 5.0}}
    quick_variants = ("nutation",)
    # sleeping_stable and sleeping_unstable run by name (and in `refsim bench sleeping_top`):
    # the default run stays under 5 minutes
    default_variants = ("nutation",)

    def scene(self, p):
        _check(p)
        q0, arm = initial_orientation(p), np.array([0.0, 0.0, p["length"]])
        body = RigidBodies(mass=[p["mass"]], inertia=[np.diag([p["I1"], p["I1"], p["I3"]])],
                           position=[quat_to_matrix(q0) @ arm], orientation=[q0],
                           angular_velocity=[initial_world_omega(p)])
        pivot = RigidPivots(body=[0], body_point=[-arm], anchor=[(0.0, 0.0, 0.0)])
        return Scene(parts=(body, pivot), gravity=(0.0, 0.0, -p["g"]))

    def t_end(self, p):
        return p["duration"]

    def dts(self, p):
        """|w| dt = 0.06 .. 0.03 in the nutation variant (w3 = 15.3 rad/s), less sleeping."""
        return [4e-3, 2e-3]

    def order_dts(self, p):
        return [1.6e-2, 8e-3]

    def reference_dt(self, p):
        return 2e-3

    def fastest_rate(self, p) -> float:
        """max(w3, I3 w3 / I1', Omega_c): the spin, the nutation rate, the precession scale."""
        w3 = spin(p)
        return max(w3, p["I3"] * w3 / pivot_moments(p)[0], threshold_rate(p))

    def instability_gain(self, p) -> float:
        """exp(Omega_c sqrt(1 - r^2) t) below the threshold (r < 1): the linear growth of a
        tilt error; 1 for a stable top."""
        r = p["spin_ratio"]
        return float(np.exp(threshold_rate(p) * np.sqrt(1.0 - r * r) * p["duration"])) \
            if r < 1.0 else 1.0

    def motion_scale(self, p):
        """max |sin tilt| of the reference: the size of e3's horizontal motion."""
        t = np.linspace(0.0, p["duration"], 2001)
        w_body, q = reference_state(p, t)
        return float(np.max(np.sin(axis_observables(p, q, w_body)["tilt"])))

    def error_floor(self, p):
        """Round-off: eps a step on the unit axis over the finest run, times the gain."""
        return p["duration"] / min(self.dts(p)) * EPS * self.instability_gain(p)

    def observables(self, p, obs):
        q = self.first_body(obs, "q")
        return axis_observables(p, q, self.body_omega(obs))

    def reference(self, p, t):
        w_body, q = reference_state(p, t)
        return axis_observables(p, q, w_body)

    def energy(self, p, obs):
        w_body = self.body_omega(obs)
        e3z = quat_to_matrix(self.first_body(obs, "q"))[:, 2, 2]
        return 0.5 * np.sum(pivot_moments(p) * w_body ** 2, axis=-1) \
            + p["mass"] * p["g"] * p["length"] * e3z

    def energy_scale(self, p):
        """1/2 I3 w3^2 + M g l: the spin's kinetic energy and the potential's range / 2."""
        return 0.5 * p["I3"] * spin(p) ** 2 + p["mass"] * p["g"] * p["length"]

    def extra_metrics(self, p, obs, observed, reference):
        l3 = p["I3"] * spin(p)
        lz_drift = np.max(np.abs(observed["L_z"] - l3 * np.cos(p["tilt"]))) / l3
        l3_drift = np.max(np.abs(observed["L_3"] - l3)) / l3
        return {"momentum_drift": float(max(lz_drift, l3_drift)),
                "L_z_drift": float(lz_drift), "L_3_drift": float(l3_drift),
                **self.orientation_metrics(obs)}

    def modes(self, p) -> list[tuple[float, float]]:
        """[(amplitude, rate)] of e3's horizontal motion: linearised about the upright
        (module docstring) a stable top released from rest moves e3 by sin theta0 (W+ e^{i W-
        Omega_c t} - W- e^{i W+ Omega_c t}) / (W+ - W-): a slow precession of amplitude
        sin theta0 W+ / (W+ - W-) at W- Omega_c and a nutation of amplitude sin theta0 W- /
        (W+ - W-), taken at the fast top's nutation rate I3 w3 / I1' (>= W+ Omega_c, the
        linear one). Below the threshold (no oscillating modes): one mode, the motion scale at
        `fastest_rate` (the bound uses the linearised top's exact discrete solution there)."""
        r = p["spin_ratio"]
        if r <= 1.0:
            return [(self.motion_scale(p), self.fastest_rate(p))]
        root = np.sqrt(r * r - 1.0)
        w_plus, w_minus = r + root, r - root
        tilt = np.sin(p["tilt"])
        nutation = p["I3"] * spin(p) / pivot_moments(p)[0]
        return [(tilt * w_minus / (w_plus - w_minus), nutation),
                (tilt * w_plus / (w_plus - w_minus), threshold_rate(p) * w_minus)]

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        """SAFETY x (a stable top: the named method's phase and amplitude errors on e3's two
        modes, from its stability function, and the kick-drift methods' explicit gyroscopic
        term; below the threshold: the exact discrete solution's error on the linearised top,
        growth included) + the chart's turning error times |w x e3| / |w| and the printed
        matrix's stretch (times the instability gain) + round-off (times the gain)."""
        scale, omega, gain = self.motion_scale(p), self.fastest_rate(p), self.instability_gain(p)
        omega_t = omega * p["duration"]
        rtol = adaptive_rtol(integrator)
        if rtol is not None:
            return 10 * rtol * scale * omega_t * gain, ADAPTIVE_REASON + (
                f", times the instability gain {gain:.3g}")
        printed = engine_variant == "matrix_printed"
        steps = p["duration"] / dt
        speed, off_axis = orbit_rates(p)
        lam = abs(p["I3"] - pivot_moments(p)[0]) / pivot_moments(p)[0] * spin(p)
        modes = self.modes(p)
        extra = chart_error(integrator, engine_variant or "quat_exp", off_axis, speed, dt,
                            steps)
        roundoff = steps * EPS * (1.0 + omega_t)
        if p["spin_ratio"] <= 1.0:  # growing: the linearised top's exact discrete solution
            linear = linear_top_error(integrator, p, dt)
            bound = linear + gain * (extra + mode_error(
                integrator, [], dt, steps, printed=(scale, speed) if printed else None))
            # each rounding (eps of the unit axis) grows with the unstable mode, by the gain
            # at most (which replaces the stable top's linear phase growth 1 + W t)
            roundoff = steps * EPS * max(gain, 1.0 + omega_t)
            reason = (f"order {order}: {SAFETY:g} x (the exact discrete solution's error of the "
                      f"method on the linearised top, {linear:.3g}: I1' u'' = M g l u + I3 w3 "
                      "J u', u = e3's horizontal part, from rest at sin theta0 (refsim.expected."
                      "discrete_solution, its explicit gyroscopic kick included), against "
                      "its exact solution, the growing mode included; plus, times the "
                      f"instability gain {gain:.3g}, the orientation chart's turning error at "
                      f"max|w| = ")
        else:
            bound = extra + mode_error(integrator, modes, dt, steps, kick=(scale, lam),
                                       printed=(scale, speed) if printed else None)
            text = ", ".join(f"{a:.3g} at {w:.3g} rad/s" for a, w in modes)
            reason = (f"order {order}: {SAFETY:g} x (sum over e3's modes (amplitude a, rate w: "
                      f"{text}) of a n (|phi(w h)| + |alpha(w h)|), n = {steps:.0f}: the "
                      "method's phase and amplitude errors per step (refsim.expected."
                      "oscillator_rates) on the precession and the nutation of the linearised "
                      "top; plus the orientation chart's turning error at max|w| = ")
        reason += (
                   f"{speed:.3g} rad/s (_bounds.chart_step_angle; 0 for the exponential map) "
                   f"times max |w x e3| / |w| = {off_axis:.3g}, the share of a turn about w "
                   f"that moves e3); safety factor {SAFETY:g}")
        if method_name(integrator) in KICK_METHODS and p["spin_ratio"] > 1.0:
            reason += KICK_REASON.format(rate=lam, amplitude=scale)
        if printed:
            reason += PRINTED_REASON.format(rate=speed)
        reason += (f"; plus round-off n eps max(1 + W t, gain) = {roundoff:.3g}: eps a step, "
                   "each step's rounding carried by a phase error growing with W t or by the "
                   "unstable mode")
        return SAFETY * bound + roundoff, reason


def linear_top_error(spec, p, dt) -> float:
    """max over the run of |u_k - u(t_k)|: the named method's exact discrete solution
    (`refsim.expected.discrete_solution`) on the top linearised about the upright, u'' =
    Omega_c^2 u + (I3 w3 / I1') J u' (J the quarter turn about z; u = e3's horizontal part,
    from rest at (sin theta0, 0)), against its exact solution exp(h M)^k."""
    rate2 = threshold_rate(p) ** 2
    gyro = p["I3"] * spin(p) / pivot_moments(p)[0]
    accel = rate2 * np.eye(2)
    damping = gyro * np.array([[0.0, -1.0], [1.0, 0.0]])
    steps = np.arange(1, int(round(p["duration"] / dt)) + 1)
    start = np.array([np.sin(p["tilt"]), 0.0])
    x, _ = discrete_solution(spec, accel, damping, start, [0.0, 0.0], dt, steps)
    flow = expm(dt * np.block([[np.zeros((2, 2)), np.eye(2)], [accel, damping]]))
    z, exact = np.concatenate([start, [0.0, 0.0]]), np.empty((len(steps), 2))
    for k in range(len(steps)):
        z = flow @ z
        exact[k] = z[:2]
    return float(np.max(np.linalg.norm(x - exact, axis=1)))


def orbit_rates(p) -> tuple[float, float]:
    """(max |w|, max |w x e3| / |w|) over the reference run (1001 samples)."""
    w_body, _ = reference_state(p, np.linspace(0.0, p["duration"], 1001))
    speed = np.linalg.norm(w_body, axis=1)
    return float(np.max(speed)), float(np.max(np.linalg.norm(w_body[:, :2], axis=1) / speed))


CASE = HeavyTop()
