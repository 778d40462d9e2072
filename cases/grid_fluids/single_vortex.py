"""LeVeque's single vortex (SIAM J. Numer. Anal. 33, 1996, sec. 9.5; MODELS.md section 5):
a disk of radius 0.15 at (0.5, 0.75) in the unit square, stretched into a spiral by
u = sin^2(pi x) sin(2 pi y) cos(pi t/T), v = -sin(2 pi x) sin^2(pi y) cos(pi t/T) and brought
back: cos(pi (T - t)/T) = -cos(pi t/T), so the flow from T/2 to T undoes the flow from 0 to
T/2 and the shape at T is the shape at 0 exactly. That is the only exact reference (the
spiral at T/2 has no closed form): the case observes at t = 0 and t = T only.

Default T = 1 s (LeVeque's tests used T = 1.5 and more; Enright et al. 2002 used T = 8 for
level sets: `--param period=8 --param n=128`, 10-20 s a scheme; particles at T = 8: variant
`particles_t8`); the level set on n = 32 cells a side (the disk 4.8 cells in radius), dt = h
(CFL 1 at the largest speed, 1 m/s); the next grid by `--param n=64`; variant `t2` (T = 2 s:
the bilinear level set loses the whole disk) by name, with the reinitialised level set beside
it. Particles: 256 markers on the circle, dt = T/16, T/32, T/64 (and T/256 for the order fit).

What the schemes do (measured with tests/cases/test_grid_fluids_advection.py; T = 1, dt = h):
the bilinear level set diffuses (numerical viscosity ~ a (1 - a) h^2 / (2 dt) per axis, a the
fractional CFL, up to h/8 at dt = h): the disk shrinks, area loss -33 %, -14 %, -6.4 % at
n = 32, 64, 128 (first order in h); Catmull-Rom keeps the area within 1 %; the euler
backtrace's first-order phase error adds a displacement ~ dt (the spiral does not fully
unwind). The particles' error is each stepper's global error at T: measured orders 1.0 (explicit
Euler), 3.0 (midpoint, Heun, Ralston) and 5.0 (RK4), one above the nominal 2 and 4: the field's
time symmetry u(T - t) = -u(t) cancels their leading error term between the run's halves.
Reinitialisation (formulation reinit_every_16, refsim.models.grid_fluid.level_set.redistance)
measured, rk2 backtrace, area loss without -> with: bilinear -32.7 % -> -31.2 % (n = 32),
-14.0 % -> -12.1 % (n = 64); Catmull-Rom +0.7 % -> -1.6 %, +0.01 % -> -0.6 %: redistancing
to the interpolant's chords shrinks a convex shape by O(h^2 / r) each time, which the cubic
level set did not lose. Compared observable `shape_error` and the bounds:
cases/grid_fluids/_advection.py (the scheme's exact discrete solution, computed by the case
on its own velocity).
"""
from __future__ import annotations

import math

import numpy as np

from refsim.case import Param
from refsim.models.grid_fluid.level_set import disk_sdf
from refsim.scene.prescribed_flow import PrescribedFlow

from ._advection import AdvectionCase

CENTRE, RADIUS = (0.5, 0.75), 0.15


class SingleVortex(AdvectionCase):
    name = "single_vortex"
    description = ("LeVeque's single vortex: a disk stretched into a spiral and brought back "
                   "at T; a semi-Lagrangian level set's area loss and shape error, marker "
                   "particles' error, against the exact return")
    tags = ("grid_fluids", "advection", "level_set", "exact")
    params = {**AdvectionCase.common_params,
              "period": Param(1.0, 0.0, 100.0, "T (s): the flow reverses at T/2",
                              low_inclusive=False),
              "cfl": Param(1.0, 0.0, 10.0, "level set: dt = cfl h (the largest speed is "
                           "1 m/s)", low_inclusive=False)}
    variants = {"default": {}, "particles": {"method": "particles"},
                "t2": {"period": 2.0}, "particles_t8": {"method": "particles", "period": 8.0}}
    default_variants = quick_variants = ("default", "particles")
    # the level set redistanced every 16 steps (formulation reinit_every_16) beside none: on
    # the longer run by name (t2, 64 steps), outside the default run's budget
    alternatives_variants = ("t2",)

    def domain(self, p):
        return 1.0

    def flow_part(self, p):
        return PrescribedFlow("leveque_vortex", period=p["period"])

    def velocity(self, p, t, points):
        """The case's own single vortex (the model's expressions, in the same order)."""
        x, y = points[..., 0], points[..., 1]
        g = np.cos(np.pi * t / p["period"])
        sx, sy = np.sin(np.pi * x), np.sin(np.pi * y)
        return np.stack([sx * sx * np.sin(2 * np.pi * y) * g,
                         -np.sin(2 * np.pi * x) * sy * sy * g], axis=-1)

    def matrix(self, p):
        return None  # not affine

    def sdf(self, p, points, t=0.0):
        """The disk's signed distance; the exact shape is the disk at t = 0 and t = T only."""
        if not (t == 0.0 or math.isclose(t, p["period"], rel_tol=1e-12)):
            raise ValueError(f"single_vortex: the exact shape is known at t = 0 and T only, "
                             f"asked at t = {t}")
        return disk_sdf(points, CENTRE, RADIUS)

    def boundary(self, p, k):
        a = 2 * np.pi * np.arange(k) / k
        return np.column_stack([CENTRE[0] + RADIUS * np.cos(a), CENTRE[1] + RADIUS * np.sin(a)])

    def exact_area(self, p):
        return math.pi * RADIUS ** 2

    def exact_markers(self, p, t):
        t = np.asarray(t, float)
        known = (t == 0.0) | np.isclose(t, p["period"], rtol=1e-12, atol=0.0)
        if not np.all(known):
            raise ValueError("single_vortex: the markers' exact positions are known at t = 0 "
                             "and T only")
        return np.broadcast_to(self.markers(p), (len(t),) + self.markers(p).shape)

    def t_end(self, p):
        return float(p["period"])

    def sample_dt(self, p):
        return self.t_end(p)  # observed at 0 and T: the exact shape is known there only

    def steps_level_set(self, p):
        return max(1, round(self.t_end(p) / (p["cfl"] * self.grid(p).h)))

    def particle_steps(self, p):
        base = 16 * max(1, round(p["period"]))
        return [base, 2 * base, 4 * base]


CASE = SingleVortex()
