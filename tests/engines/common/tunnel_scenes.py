"""Scenes for the engines' tunnelling tests (issue 28, a small fast sphere against a thin plate).

Sphere k flies along its plate's normal at `ratio[k]` times the geometric threshold
(w + 2r) / dt, started so that one step ends `gap` before the entry face (its centre at
-(w/2 + r + gap) along the normal): the next step is the one that decides. Each sphere has
its own plate, in lanes 10 r apart along z (pymunk's plane is a 3D scene's x-z plane), so
spheres never meet. `run` returns each centre's signed distance along the normal from its
plate's mid-plane (> 0: through), the normal velocity, and the settings.
"""
from __future__ import annotations

import numpy as np

from refsim.registry import get_engine
from refsim.scene import ContactModel, Particles, Plates, Scene

R, W, DT = 0.05, 0.02, 1e-3  # m, m, s: a 5 cm sphere, a 2 cm plate, 1 ms
GAP = 1e-6  # m: where the step before the decisive one ends, short of the entry face


def speeds(ratios, r=R, w=W, dt=DT):
    return np.asarray(ratios, float) * (w + 2 * r) / dt


def scene(ratios, r=R, w=W, dt=DT, e=1.0, gap=GAP, normal=(1.0, 0.0, 0.0)):
    n = len(ratios)
    nrm = np.asarray(normal, float) / np.linalg.norm(normal)
    v = speeds(ratios, r, w, dt)
    lanes = np.zeros((n, 3))
    lanes[:, 2 if abs(nrm[2]) < 0.5 else 0] = 10 * r * np.arange(n)
    start = lanes - (0.5 * w + r + gap + v[:, None] * dt) * nrm
    parts = (Particles(mass=np.ones(n), position=start, velocity=v[:, None] * nrm,
                       radius=np.full(n, r), inertia=np.full(n, 0.4 * r * r)),
             Plates(center=lanes, normal=np.tile(nrm, (n, 1)), thickness=np.full(n, w),
                    half_size=np.full(n, 4 * r)))
    return Scene(parts=parts, contact=ContactModel(e), gravity=(0.0, 0.0, 0.0)), lanes, nrm


def build(engine, formulation, ratios, integrator=None, **kw):
    """The engine's Sim of `scene(ratios, **kw)` at `integrator` (default: its first offered)."""
    eng = get_engine(engine)
    sc, lanes, nrm = scene(ratios, **kw)
    integrator = integrator or eng.offered_integrators(sc)[0]
    return eng.build(sc, kw.get("dt", DT), integrator, formulation), lanes, nrm


def run(engine, formulation, ratios, steps=20, hook=None, integrator=None, **kw):
    """(distance past the mid-plane (n,), normal velocity (n,), full velocity (n, 3),
    settings) after `steps` steps; `hook(sim)` runs before stepping (to plant a defect)."""
    sim, lanes, nrm = build(engine, formulation, ratios, integrator, **kw)
    try:
        if hook is not None:
            hook(sim)
        sim.step(steps)
        out = sim.observe()
        return (out["x"] - lanes) @ nrm, out["v"] @ nrm, out["v"], sim.settings()
    finally:
        sim.close()


def first_tunnelling(engine, formulation, ratios, **kw):
    """The smallest ratio of `ratios` (sorted) whose sphere went through, and the count."""
    through, *_ = run(engine, formulation, ratios, **kw)
    crossed = np.asarray(ratios)[through > 0]
    return (float(crossed.min()) if len(crossed) else None), int(np.sum(through > 0))
