"""Springs and linear drag, which pybullet lacks, applied as external forces every step.

`applyExternalForce` (WORLD_FRAME, at the centre of mass) before every `stepSimulation`, from
the state at the start of the step (pybullet clears the force after every step). That is
refsim's kick-drift exactly: v += h a(x, v); x += h v. Those Python calls are the engine's real
cost in this use and are kept in the timing.
"""
from __future__ import annotations

import math

from .runtime import body_state

_ZERO = (0.0, 0.0, 0.0)


class ForceTerms:
    """Springs and linear drag, which pybullet lacks, as per-step external forces: `springs`
    (`Spring` records, () for none), `drag` (the linear drag coefficient, 1/s), `nbody` (how
    many bodies).

    Plain Python on tuples (not numpy): for one or two bodies this is several times cheaper, so
    the timing is pybullet's call overhead rather than the adapter's arithmetic."""

    def __init__(self, springs, drag: float, nbody: int):
        self.springs = [(s.body, s.other, s.anchor, s.stiffness, s.rest_length, s.damping)
                        for s in springs]
        self.drag = drag
        self.nbody = nbody
        needed = {s[0] for s in self.springs} | {s[1] for s in self.springs if s[1] is not None}
        self.bodies = sorted(range(self.nbody) if self.drag > 0 else needed)
        self.needs_v = self.drag > 0 or any(s[5] > 0 for s in self.springs)

    def names(self):
        return (["drag (external force)"] if self.drag > 0 else []) + \
            (["springs (external force)"] if self.springs else [])

    def describe(self, handles):
        if not self.bodies:
            return {"python_calls_per_step": 1, "external_forces": "none"}
        # stepSimulation, then per forced body: its state (a free base reads position and,
        # when a force needs it, velocity apart; a link both at once) and one force
        free_reads = 2 if self.needs_v else 1
        calls = 1 + sum(1 + (free_reads if handles[i][1] < 0 else 1) for i in self.bodies)
        return {
            "external_forces": self.names(),
            "external_force_method": (
                "applyExternalForce(WORLD_FRAME, at the centre of mass) before every "
                "stepSimulation, from the state at the start of the step (force cleared after "
                "every step): kick-drift, refsim's symplectic_euler"),
            "python_calls_per_step": calls,
            "python_per_step_note": ("pybullet has no springs or linear drag: a Python round "
                                     "trip per body per step (state read, force write) is the "
                                     "engine's real cost in this use, kept in the timing"),
        }

    def forces(self, x, v):
        """Force per body in self.bodies (a dict of 3-lists), from the positions and velocities
        (tuples) of every body."""
        drag = self.drag
        f = {i: ([-drag * c for c in v[i]] if drag else [0.0, 0.0, 0.0]) for i in self.bodies}
        for body, other, anchor, k, rest, c in self.springs:
            free = other is None
            fs = spring_force(x[body], anchor if free else x[other], v[body],
                              _ZERO if free or not c else v[other], k, rest, c)
            fb = f[body]
            fb[0] += fs[0]
            fb[1] += fs[1]
            fb[2] += fs[2]
            if not free:
                fo = f[other]
                fo[0] -= fs[0]
                fo[1] -= fs[1]
                fo[2] -= fs[2]
        return f

    def applier(self, p, cid, handles):
        """A no-argument function applying this step's forces, or None when there are none."""
        if not self.bodies:
            return None
        apply, world = p.applyExternalForce, p.WORLD_FRAME
        x, v = [None] * self.nbody, [None] * self.nbody
        needs_v = self.needs_v

        def apply_forces():
            for i in self.bodies:
                x[i], v[i] = body_state(p, cid, *handles[i], velocity=needs_v)
            for i, force in self.forces(x, v).items():
                uid, link = handles[i]
                apply(uid, link, force, x[i], world, physicsClientId=cid)
        return apply_forces


def spring_force(x, xo, v, vo, k, rest, c):
    """-k (|d| - L0) u - c (dv . u) u on the body end, d = x - xo, u = d / |d| (0 when |d| = 0)."""
    d = (x[0] - xo[0], x[1] - xo[1], x[2] - xo[2])
    length = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    if length == 0.0:
        return (0.0, 0.0, 0.0)
    u = (d[0] / length, d[1] / length, d[2] / length)
    scale = -k * (length - rest)
    if c:
        dv = (v[0] - vo[0], v[1] - vo[1], v[2] - vo[2])
        scale -= c * (dv[0] * u[0] + dv[1] * u[1] + dv[2] * u[2])
    return (scale * u[0], scale * u[1], scale * u[2])
