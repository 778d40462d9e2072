"""Zalesak's slotted disk (J. Comput. Phys. 31, 1979; MODELS.md section 5): in [0, 100]^2 m a
disk of radius 15 at (50, 75) with a slot 5 wide and 25 long cut up from its bottom (the slot
from the circle to y = 85), turned rigidly about (50, 50) by u = pi/314 (50 - y),
v = pi/314 (x - 50): one turn in 628 s. The exact shape at every t is the start turned by
omega t (its signed distance: the start's, at the points turned back), so the case observes
4 times a turn; after whole turns the shape is the start.

One turn. The default run moves the markers (variant `particles`); the level set (variant
`level_set`, by name: 9 schemes) on n = 64 cells a side (h = 1.5625 m: the slot 3.2 cells
wide), 64 steps a turn (dt = 9.8 s: the disk's far edge, r = 40 m, moves 2.5 cells a step),
from the slotted disk's exact signed distance (refsim.models.grid_fluid.level_set.
slotted_disk_sdf, derived there); Zalesak's 100^2 grid by `--param n=100` (with `--param
steps=628` his dt = 1 s: bilinear then loses 92 % of the area, its numerical diffusion growing
with the number of steps, h^2 / dt; 2-8 s a scheme). Particles: 256
markers spread evenly along the boundary (arc, slot walls, slot end), 32, 64, 128 steps a turn
(and 512 for the order fit); the rotation is affine, so implicit Euler runs too, and each
stepper's discrete solution is c + R(h M)^k (p_0 - c) (R its stability function: the radius
grows by |R(i omega h)| a step, cases/first_order_fields/advection_vortex.py).

What the schemes do (tests/cases/test_grid_fluids_advection.py): the bilinear level set rounds
the slot's corners and shrinks the disk (numerical diffusion a (1 - a) h^2 / (2 dt) per axis);
Catmull-Rom keeps the slot; the rotation is exactly linear, so the backtrace's error is its
phase and radius error per step. Reinitialisation every 16 steps (formulation reinit_every_16),
rk2 backtrace, n = 64: bilinear area loss -20.5 % -> -6.4 % (symmetric difference 53 % -> 39 %
of the area), Catmull-Rom +0.4 % -> -2.8 % (6.8 % -> 9.7 %). Compared observable
`shape_error` and the bounds: cases/grid_fluids/_advection.py (the scheme's exact discrete
solution, computed by the case on its own velocity).
"""
from __future__ import annotations

import math

import numpy as np

from refsim.case import Param
from refsim.models.grid_fluid.level_set import slotted_disk_sdf
from refsim.scene.prescribed_flow import PrescribedFlow

from ._advection import AdvectionCase

L_BOX, PIVOT = 100.0, (50.0, 50.0)
CENTRE, RADIUS, WIDTH, LENGTH = (50.0, 75.0), 15.0, 5.0, 25.0
OMEGA = math.pi / 314.0  # rad/s: one turn in 628 s


class Zalesak(AdvectionCase):
    name = "zalesak"
    description = ("Zalesak's slotted disk turned once about the box's centre: a "
                   "semi-Lagrangian level set's area loss and shape error, marker particles' "
                   "error, against the exact rotation")
    tags = ("grid_fluids", "advection", "level_set", "exact")
    params = {**AdvectionCase.common_params,
              "n": Param(64, 8, 4096, "cells a side of the level set's grid on [0, 100] m"),
              "turns": Param(1.0, 0.0, 100.0, "run length in turns (628 s each)",
                             low_inclusive=False),
              "steps": Param(64, 1, 1e6, "level set: steps a turn")}
    variants = {"particles": {"method": "particles"}, "level_set": {}}
    # the level set's 9 schemes cost ~0.1-0.3 s each (and as much again for their bounds):
    # by name (--variant level_set), beside the single vortex's level set in the default run
    default_variants = quick_variants = ("particles",)
    alternatives_variants = ("level_set",)  # redistanced every 16 steps, beside none

    def domain(self, p):
        return L_BOX

    def flow_part(self, p):
        return PrescribedFlow("zalesak_rotation", omega=OMEGA, centre=PIVOT)

    def velocity(self, p, t, points):
        """The case's own rotation (the model's expressions, in the same order)."""
        x, y = points[..., 0], points[..., 1]
        return np.stack([OMEGA * (PIVOT[1] - y), OMEGA * (x - PIVOT[0])], axis=-1)

    def pivot(self, p):
        return np.array(PIVOT)

    def matrix(self, p):
        return np.array([[0.0, -OMEGA, 0.0], [OMEGA, 0.0, 0.0], [0.0, 0.0, 0.0]])

    @staticmethod
    def _turn(points, angle):
        """points (..., 2) turned by angle about the pivot."""
        c, s = math.cos(angle), math.sin(angle)
        x, y = points[..., 0] - PIVOT[0], points[..., 1] - PIVOT[1]
        return np.stack([PIVOT[0] + c * x - s * y, PIVOT[1] + s * x + c * y], axis=-1)

    def sdf(self, p, points, t=0.0):
        """The exact shape at t: the start's signed distance at the points turned back."""
        return slotted_disk_sdf(self._turn(points, -OMEGA * t), CENTRE, RADIUS, WIDTH, LENGTH)

    def boundary(self, p, k):
        """k points evenly by arc length, counter-clockwise (material on the left): the kept
        arc from its bottom-right end over the top, the left slot wall up, the slot's end,
        the right wall down."""
        half = 0.5 * WIDTH
        alpha = math.asin(half / RADIUS)
        y_b, y_t = CENTRE[1] - math.sqrt(RADIUS ** 2 - half ** 2), CENTRE[1] - RADIUS + LENGTH
        pieces = np.array([RADIUS * (2 * math.pi - 2 * alpha), y_t - y_b, WIDTH, y_t - y_b])
        ends = np.concatenate([[0.0], np.cumsum(pieces)])
        s = ends[-1] * np.arange(k) / k
        piece = np.searchsorted(ends, s, side="right") - 1
        u = s - ends[piece]
        a = -math.pi / 2 + alpha + u / RADIUS
        xs = np.select([piece == 0, piece == 1, piece == 2, piece == 3],
                       [CENTRE[0] + RADIUS * np.cos(a), np.full(k, CENTRE[0] - half),
                        CENTRE[0] - half + u, np.full(k, CENTRE[0] + half)])
        ys = np.select([piece == 0, piece == 1, piece == 2, piece == 3],
                       [CENTRE[1] + RADIUS * np.sin(a), y_b + u, np.full(k, y_t), y_t - u])
        return np.column_stack([xs, ys])

    def exact_area(self, p):
        """pi R^2 less the slot inside the disk, the strip |x - c_x| < a = w/2 from the circle's
        bottom -sqrt(R^2 - x^2) to L - R = 10 m above the centre (inside the disk):
        w (L - R) + int_{-a}^{a} sqrt(R^2 - x^2) dx = w (L - R) + a sqrt(R^2 - a^2) +
        R^2 asin(a / R)."""
        a = 0.5 * WIDTH
        return math.pi * RADIUS ** 2 - (WIDTH * (LENGTH - RADIUS) + a * math.sqrt(
            RADIUS ** 2 - a ** 2) + RADIUS ** 2 * math.asin(a / RADIUS))

    def exact_markers(self, p, t):
        start = self.markers(p)
        return np.stack([self._turn(start, OMEGA * tk) for tk in np.asarray(t, float)])

    def t_end(self, p):
        return 2 * math.pi / OMEGA * p["turns"]

    def sample_dt(self, p):
        return self.t_end(p) / 4  # the exact shape is known at every t: 4 samples a turn

    def steps_level_set(self, p):
        return max(1, round(p["steps"] * p["turns"]))

    def particle_steps(self, p):
        k = max(1, round(p["turns"]))
        return [32 * k, 64 * k, 128 * k]


CASE = Zalesak()
