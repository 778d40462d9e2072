"""An SPH fluid block (the scene's FluidBlock part) as particles: the fluid lattice, the tank's wall particles,
gravity in the fluid's plane and the hydrostatic start densities. Every engine with SPH starts
from these, so all start from the same bits."""
from __future__ import annotations

import numpy as np

from refsim.models.sph import tait_density

WALL_LAYERS = 3  # dummy-particle layers: they must cover the kernel support 2h = 2.6 dx


def fluid_particles(fluid) -> np.ndarray:
    """Particle centres (n, 2) on a square lattice filling the block."""
    dx = fluid.spacing
    nx = int(round((fluid.upper[0] - fluid.lower[0]) / dx))
    ny = int(round((fluid.upper[1] - fluid.lower[1]) / dx))
    gx, gy = np.meshgrid(fluid.lower[0] + dx * (np.arange(nx) + 0.5),
                         fluid.lower[1] + dx * (np.arange(ny) + 0.5), indexing="ij")
    return np.column_stack([gx.ravel(), gy.ravel()])


def wall_particles(fluid) -> np.ndarray:
    """Bottom, left and right walls of the tank (n, 2), WALL_LAYERS deep, on the fluid's
    lattice."""
    dx, width, height = fluid.spacing, fluid.tank_width, fluid.tank_height
    depth = WALL_LAYERS * dx
    xs = np.arange(-depth + 0.5 * dx, width + depth, dx)
    ys = np.arange(-depth + 0.5 * dx, height, dx)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    solid = (pts[:, 1] < 0) | (pts[:, 0] < 0) | (pts[:, 0] > width)
    return pts[solid]


def plane_gravity(scene) -> np.ndarray:
    """Gravity (2,) in the fluid's plane: (x, y) of a 2D scene, (x, z) of a 3D one."""
    gravity = np.asarray(scene.gravity, float)
    return gravity[:2] if scene.dim == 2 else gravity[[0, 2]]


def hydrostatic_densities(fluid, x, gravity) -> np.ndarray:
    """Tait density (n,) of each fluid particle at rest under the block's own weight: pressure
    rho0 |g_y| (y_top - y) at depth y_top - y."""
    depth = fluid.upper[1] - x[:, 1]
    return tait_density(fluid.density * abs(gravity[1]) * depth, fluid.density,
                        fluid.sound_speed)
