"""`refsim bench rigid`: free rigid bodies, body-steps per second, every engine side by side.

N free bodies (default 10^4; --quick 10^3), each with its own full inertia tensor (random
symmetric positive definite, principal moments 1..1.9 kg m^2: every body physical, A + B > C
by a margin, which MuJoCo checks), orientation and angular velocity
(|w| about 1 rad/s), no gravity, dt = 1 ms: semi-implicit ("symplectic") Euler in every engine
that has it, refsim's RK4 beside it. Each engine gets one Sim holding all N bodies; after a
warm-up of WARMUP steps (taichi's compilation, MuJoCo's first step), `step(steps)` is timed
REPEATS times and the best is kept (body-steps/s = N steps / seconds).

The same model, so the same numbers: refsim's quat_exp symplectic Euler, MuJoCo's Euler (free
joint: explicit gyroscopic term, then the quaternion moved by the exponential map) and taichi's
quat_exp kernel take the same step, and pybullet's multibody base the same again (its
rotation-limit clamp aside, never reached at |w| dt = 1e-3). The bench prints the largest
difference of their world angular velocities from refsim's after the timed steps: a speed
figure is only worth printing for engines that computed the same thing.
"""
from __future__ import annotations

import time

import numpy as np

WARMUP, REPEATS, DT = 5, 3, 1e-3
ENGINES = (("refsim", "quat_exp", "symplectic_euler"), ("refsim", "quat_exp", "rk4"),
           ("mujoco", "", "symplectic_euler"), ("taichi", "quat_exp", "symplectic_euler"),
           ("pybullet", "multibody", "symplectic_euler"))


def free_bodies(n: int, seed: int = 7):
    """A Scene of n free bodies with random full inertia tensors, orientations and spins."""
    from scipy.spatial.transform import Rotation

    from refsim.scene import Scene
    from refsim.scene.rigid import RigidBodies
    rng = np.random.default_rng(seed)
    axes = Rotation.random(n, random_state=rng).as_matrix()
    moments = rng.uniform(1.0, 1.9, (n, 3))  # A + B >= 2 > C: a physical body
    inertia = axes @ (moments[:, :, None] * np.swapaxes(axes, 1, 2))
    quat = Rotation.random(n, random_state=rng).as_quat()[:, [3, 0, 1, 2]]  # (w, x, y, z)
    positions = np.column_stack([np.arange(n) * 0.01, np.zeros(n), np.zeros(n)])
    spins = rng.normal(0.0, 1.0 / np.sqrt(3.0), (n, 3))
    return Scene(parts=(RigidBodies(mass=np.ones(n), inertia=inertia, position=positions,
                                   orientation=quat, angular_velocity=spins),))


def rigid_throughput(n: int, steps: int, figures: list | None = None):
    """[(label, body-steps/s, max |w - w_refsim| or nan, settings note)] for every engine
    available; each also appended to `figures` as a figure dict when given."""
    from refsim.registry import get_engine
    scene = free_bodies(n)
    rows, reference_w = [], None
    for name, variant, integrator in ENGINES:
        engine = get_engine(name)
        if not engine.available() or engine.supports(scene, integrator) is not None:
            continue
        sim = engine.build(scene, DT, integrator, variant)
        try:
            sim.step(WARMUP)
            best = min(_timed(sim, steps) for _ in range(REPEATS))
            w = sim.observe()["w"]
            threads = sim.settings().get("threads", 1)
        finally:
            sim.close()
        if integrator == "symplectic_euler" and name == "refsim":
            reference_w = w
        gap = float(np.max(np.abs(w - reference_w))) if reference_w is not None and \
            integrator == "symplectic_euler" else float("nan")
        rate = n * steps / best
        label = f"{name}{':' + variant if variant else ''} {integrator}"
        rows.append((label, rate, gap, threads))
        if figures is not None:
            figures.append(_figure(n, name, variant, integrator, steps, best, rate, gap,
                                   threads))
    return rows


def _timed(sim, steps: int) -> float:
    t0 = time.perf_counter()
    sim.step(steps)
    return time.perf_counter() - t0


def _figure(n, engine, variant, integrator, steps, seconds, rate, gap, threads) -> dict:
    return {"figure": f"free_bodies_{n}", "value": rate, "units": "body-steps/s",
            "description": f"{n} free rigid bodies (random full inertia, |w| ~ 1 rad/s, no "
                           f"gravity), dt = {DT:g} s: body-steps per second, best of "
                           f"{REPEATS} timings of {steps} steps after {WARMUP} warm-up steps",
            "engine": engine, "engine_variant": variant, "integrator": integrator,
            "dt": DT, "steps": steps, "us_per_step": seconds / steps * 1e6,
            "step_s": seconds, "repeats": REPEATS, "threads": threads, "bodies": n,
            "w_gap_to_refsim": gap, "show": ["bodies", "w_gap_to_refsim"]}


def print_rigid(n: int, rows) -> None:
    print(f"free rigid bodies: N = {n}, dt = {DT:g} s, best of {REPEATS} (body-steps/s; "
          "w gap: max |w - w_refsim| after the timed steps, same step only)")
    numpy_rate = next((r for label, r, _, _ in rows if label.startswith("refsim:quat_exp "
                                                                         "symplectic")), None)
    for label, rate, gap, threads in rows:
        ratio = f"  this / numpy {rate / numpy_rate:6.2f}" if numpy_rate else ""
        gap_text = f"w gap {gap:8.1e}" if np.isfinite(gap) else " " * 14
        print(f"   {label:36s} {rate:10.3e}  {gap_text}  ({threads} thr){ratio}")


def main(quick: bool = False) -> list[dict]:
    n, steps = (1_000, 100) if quick else (10_000, 200)
    figures = []
    print_rigid(n, rigid_throughput(n, steps, figures))
    return figures
