"""The contact damping B that gives a requested restitution e, measured in MuJoCo itself.

MuJoCo has no restitution parameter (docs/engine_notes.md#mujoco-no-restitution-parameter: the
default solref gives e ~ 0.13 whatever is asked). A bisection on B finds the B for which the
restitution MuJoCo produces (two spheres
head-on at the scene's dt with the scene's integrator), averaged over CALIBRATION_PHASES contact
onsets within a step, equals e; the largest deviation over onsets is reported as the residual.
Deterministic and cached per process."""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from .contact_params import CONTACT_STEPS, SOLVER_TOLERANCE, contact_stiffness
from .methods import METHODS

CALIBRATION_PHASES = 32  # contact onsets at (k + 1/2)/32 of a step: the mean of e
EDGE_PHASES = (1e-9, 1.0 - 1e-9)  # e(phase) peaks at the ends: the residual includes them
BISECTION_STEPS = 40  # B to 1e-12 of its range


@dataclass(frozen=True)
class RestitutionMap:
    """Damping B giving the requested e at one dt and integrator, measured in MuJoCo."""

    restitution: float
    dt: float
    integrator: str
    stiffness: float
    damping: float
    e_mean: float  # mean over the contact phases at `damping`
    residual: float  # max |e(phase) - e| at `damping`, edge phases included
    e_phases: tuple  # at the CALIBRATION_PHASES midpoints
    clamped: bool  # e outside (e(B = 1/dt), e(B = 0)): B is held at that bound

    def describe(self) -> dict:
        return {
            "method": "direct solref (-K, -B); B found by bisection so that the restitution "
                      "measured in MuJoCo (two unit spheres head-on, relative speed 2 m/s, "
                      f"condim 1, this dt and integrator), averaged over {CALIBRATION_PHASES} "
                      "contact onsets spread evenly over a step, equals e; residual_max also "
                      "covers onsets just after and just before a step boundary",
            "e_requested": self.restitution, "K": self.stiffness, "B": self.damping,
            "damping_ratio": self.damping / (2.0 * math.sqrt(self.stiffness)),
            "B_dt": self.damping * self.dt,
            "e_mean": self.e_mean, "mean_error": self.e_mean - self.restitution,
            "residual_max": self.residual,
            "e_per_phase": list(self.e_phases), "clamped_at_bound": self.clamped,
            "note": "the spread over phases comes from where in the step a contact starts "
                    "(the first overlapping step already feels the whole spring and damper); "
                    "a given impact's e lies within residual_max of e. e = 1 sits at B = 0 "
                    "(no damping can add energy), e below e(B = 1/dt) ~ 0.05 at B = 1/dt",
        }


@functools.lru_cache(maxsize=None)
def restitution_map(e: float, dt: float, integrator: str, impedance: float) -> RestitutionMap:
    """Bisection on B in [0, 1/dt] (explicit damping: stable while B dt < 2); e(B) falls
    monotonically from ~1 (B = 0) to ~0.05 (B = 1/dt) at 10-step contacts. Deterministic;
    cached per process."""
    import mujoco
    k = contact_stiffness(dt)
    xml = _calibration_xml(dt, k, METHODS[integrator].xml, impedance)
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mids = (np.arange(CALIBRATION_PHASES) + 0.5) / CALIBRATION_PHASES

    def mean_e(b):
        return float(np.mean(_phase_restitutions(mujoco, model, data, k, b, mids)))

    b, clamped = _bisect_damping(mean_e, e, 1.0 / dt)
    values = _phase_restitutions(mujoco, model, data, k, b, mids)
    edges = _phase_restitutions(mujoco, model, data, k, b, EDGE_PHASES)
    residual = float(np.max(np.abs(np.concatenate([values, edges]) - e)))
    return RestitutionMap(e, dt, integrator, k, b, float(np.mean(values)), residual,
                          tuple(float(v) for v in values), clamped)


def _bisect_damping(mean_e, e, b_max):
    """B in [0, b_max] with mean_e(B) = e (mean_e falls with B); a bound when e lies outside
    (mean_e(b_max), mean_e(0)). Returns (B, clamped)."""
    lo, hi = 0.0, b_max
    e_lo, e_hi = mean_e(lo), mean_e(hi)
    if e >= e_lo or e <= e_hi:
        return (lo if e >= e_lo else hi), True
    for _ in range(BISECTION_STEPS):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if mean_e(mid) > e else (lo, mid)
    return 0.5 * (lo + hi), False


def _calibration_xml(dt, k, integrator_xml, impedance):
    r, inertia = 0.1, 0.004  # unit masses; the result depends on neither (acceleration space)
    sphere = (f'<freejoint/><inertial pos="0 0 0" mass="1" diaginertia="{inertia} {inertia} '
              f'{inertia}"/><geom type="sphere" size="{r}" condim="1" solref="{-k!r} -0" '
              f'solimp="{impedance!r} {impedance!r} 0.001 0.5 2"/>')
    return (f'<mujoco><compiler inertiafromgeom="false"/><option timestep="{dt!r}" '
            f'gravity="0 0 0" integrator="{integrator_xml}" tolerance="{SOLVER_TOLERANCE}">'
            f'<flag eulerdamp="disable" autoreset="disable"/></option><worldbody>'
            f'<body pos="-1 0 0">{sphere}</body><body pos="1 0 0">{sphere}</body>'
            f'</worldbody></mujoco>')


def _phase_restitutions(mj, model, data, k, b, phases) -> np.ndarray:
    """e = separation speed / approach speed (2 m/s) for contacts starting (2 + phase) steps
    in; run until well past the end of the contact."""
    dt = model.opt.timestep
    model.geom_solref[:] = (-k, -b)
    out = np.empty(len(phases))
    for i, phase in enumerate(phases):
        mj.mj_resetData(model, data)
        gap = 2.0 * dt * (2.0 + phase)
        data.qpos[0], data.qpos[7] = -0.1 - gap / 2, 0.1 + gap / 2
        data.qvel[0], data.qvel[6] = 1.0, -1.0
        mj.mj_step(model, data, nstep=4 * CONTACT_STEPS + 10)
        out[i] = (data.qvel[6] - data.qvel[0]) / 2.0
    return out
