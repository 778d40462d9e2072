"""The particle-fluid step on the MAC grid: PIC, FLIP, PIC/FLIP blend or APIC (issue 27).

One step of dt (Zhu & Bridson 2005's FLIP loop; Jiang et al. 2015's APIC; the transfers of
`transfer`, the projection of `projection`):
1. P2G at the particles' positions: face velocities and masses (`transfer.p2g`);
2. cell marks: a cell holding a particle is FLUID, any other AIR (p = 0: the free surface);
3. body force: u += dt g on every face; wall faces set to 0 (`mac.enforce_boundaries`);
4. projection with those marks (`projection.PressureSystem`, p = 0 in air, walls Neumann):
   the fluid cells' divergence to the solver's tolerance;
5. faces the projection does not own (between two air cells, or air and wall) keep their
   P2G velocity where particles gave them mass (the particles' own estimate there: no body
   force, no pressure), and the rest take the mean of their known neighbours, layer by layer
   (EXTRAPOLATION_LAYERS layers, for the advection's sampler);
6. G2P by the scheme (`transfer.g2p`: FLIP adds the grid's change from step 1 to 5);
7. particles move (ADVECTIONS): "rk2_grid", the midpoint rule in the projected grid velocity
   (`mac.velocity_sampler`, bilinear, free-slip ghosts at walls as G2P has them; Bridson's
   FLIP loop), or
   "particle", x += dt v_p with the new particle velocity (the APIC papers' update); both
   keep the particles inside the box.
The splitting's own loss on a rigid rotation (omega, step theta = omega dt): the particles
carry their velocity unrotated while they move, and the projection removes its radial part.
Under "rk2_grid" a particle moves along its circle (radius error theta^4 / 8 a step), so its
velocity keeps cos(theta) of itself tangentially: KE x cos^2(theta) and L x cos(theta) per
step from the second on (the first projects the exact rigid field before any particle has
moved; the pressure is central: no torque puts it back). Under "particle" the displacement is
parallel to v_p, so x_p x v_p is unchanged (APIC's transfers keep the rest): L is kept up to
the discrete projection's torque, while each radius grows by sqrt(1 + theta^2), I by
(1 + theta^2) and KE = L^2 / (2 I) falls by 1 / (1 + theta^2) per step. Both are first order
in dt at a fixed time (tests/models/test_grid_fluid_transfer_step.py measures them).
Observables: x, v (n, 3) with z = 0 (the particles), grid.u, grid.v (the projected faces),
grid.p (the kinematic pressure); no loop over particles or cells.
"""
from __future__ import annotations

import numpy as np

from refsim.scene.fluid_grid import AIR, FLUID

from .mac import MacGrid, enforce_boundaries, velocity_sampler
from .projection import PressureSystem
from .transfer import FaceField, MacLayout, TransferScheme, g2p, p2g, stencils

EXTRAPOLATION_LAYERS = 3
# the particles' velocity sampler at walls: free slip, the G2P transfer's own rule (transfer:
# the tangential velocity even about a wall); no-slip ghosts here would drag the particles
# next to a wall while G2P lets them slide (measured on flip_dam_break: APIC's front 0.48
# from Martin & Moyce with no-slip ghosts, against 0.08 moving the particles by their own v)
PARTICLE_WALLS = "even"
ADVECTIONS = ("rk2_grid", "particle")


def cell_marks(layout: MacLayout, x: np.ndarray) -> np.ndarray:
    """(nx, ny) int8: FLUID where a cell holds a particle, else AIR."""
    i = np.clip((x[:, 0] / layout.h).astype(np.intp), 0, layout.nx - 1)
    j = np.clip((x[:, 1] / layout.h).astype(np.intp), 0, layout.ny - 1)
    count = np.bincount(i * layout.ny + j, minlength=layout.nx * layout.ny)
    return np.where(count.reshape(layout.nx, layout.ny) > 0, FLUID, AIR).astype(np.int8)


def _shifted(a: np.ndarray, axis: int, step: int) -> tuple:
    """a shifted by one along axis (step +-1) and whether the shifted entry exists."""
    out, ok = np.zeros_like(a), np.zeros(a.shape, bool)
    src = [slice(None)] * 2
    dst = [slice(None)] * 2
    src[axis] = slice(None, -1) if step > 0 else slice(1, None)
    dst[axis] = slice(1, None) if step > 0 else slice(None, -1)
    out[tuple(dst)] = a[tuple(src)]
    ok[tuple(dst)] = True
    return out, ok


def extrapolate(values: np.ndarray, known: np.ndarray, layers: int) -> np.ndarray:
    """Fill unknown faces with the mean of their known 4-neighbours, `layers` times (a loop
    over layers, each a few whole-array operations)."""
    values, known = values.copy(), known.copy()
    for _ in range(layers):
        total, count = np.zeros_like(values), np.zeros(values.shape)
        for axis in (0, 1):
            for step in (1, -1):
                val, ok = _shifted(values, axis, step)
                kn, _ = _shifted(known.astype(float), axis, step)
                use = ok & (kn > 0)
                total += np.where(use, val, 0.0)
                count += use
        fill = ~known & (count > 0)
        values[fill] = total[fill] / count[fill]
        known = known | fill
    return values


class ParticleFluid:
    """Particles (x, vel (n, 2), masses m) on a MAC grid, stepped by `scheme`.

    grid: `mac.MacGrid`; gravity (2,) m/s^2; method and rtol: the projection's solver and
    relative residual target; advection in ADVECTIONS. State: x, vel, c (APIC's affine
    vectors (n, 2, 2), else None), and after a step the grid's u, v, p and the projection's
    info."""

    def __init__(self, grid: MacGrid, scheme: TransferScheme, x, vel, m, gravity=(0.0, 0.0),
                 method: str = "direct", rtol: float = 1e-10, advection: str = "rk2_grid"):
        if advection not in ADVECTIONS:
            raise ValueError(f"advection must be one of {ADVECTIONS}, got {advection!r}")
        self.grid, self.scheme, self.advection = grid, scheme, advection
        self.layout = MacLayout(grid.nx, grid.ny, grid.h, tuple(grid.periodic))
        self.x = np.array(x, float)[:, :2]
        self.vel = np.array(vel, float)[:, :2]
        self.m = np.broadcast_to(np.asarray(m, float), self.x.shape[:1]).copy()
        self.c = np.zeros((len(self.x), 2, 2)) if scheme.affine else None
        self.gravity = np.asarray(gravity, float)[:2]
        self.method, self.rtol = method, rtol
        self.u = np.zeros(self.layout.face_shape(0))
        self.v = np.zeros(self.layout.face_shape(1))
        self.p = np.zeros((grid.nx, grid.ny))
        self.info: dict = {}

    @classmethod
    def from_scene(cls, scene, scheme: TransferScheme, method: str = "direct"):
        """From a scene of one `FluidGrid` (geometry, walls, gravity switch, rtol) and one
        `Particles` part (the fluid's particles: x, v, masses; z ignored); the particle
        advection from scene.meta["particle_advection"] (default "rk2_grid"); APIC's affine
        vectors start as scene.meta["velocity_gradient"] (2 x 2, row a = grad of component
        a: the initial field's gradient where it is affine), else 0."""
        from refsim.scene import FluidGrid, Particles
        part, particles = scene.part(FluidGrid), scene.part(Particles)
        gravity = np.asarray(scene.gravity, float)[:2] if part.gravity else (0.0, 0.0)
        sim = cls(MacGrid.of(part), scheme, particles.position, particles.velocity,
                  particles.mass, gravity, method, part.rtol,
                  scene.meta.get("particle_advection", ADVECTIONS[0]))
        if sim.c is not None and "velocity_gradient" in scene.meta:
            sim.c[:] = np.asarray(scene.meta["velocity_gradient"], float)[:2, :2]
        return sim

    def grid_forces(self, field: FaceField, dt: float) -> tuple:
        """Steps 3 to 5: the body force and projection on the faces the projection owns; the
        other faces keep their P2G velocity where particles gave them mass, the rest take
        their neighbours' mean."""
        u, v = field.u + dt * self.gravity[0], field.v + dt * self.gravity[1]
        enforce_boundaries(u, v, self.grid)
        system = PressureSystem(self.grid, cell_marks(self.layout, self.x))
        u, v, self.p, self.info = system.project(u, v, dt, self.method, self.rtol)
        owned = np.zeros(system.n_u + v.size, bool)
        owned[system.face_index] = True
        out = []
        for a, (projected, own) in enumerate(zip((u, v), system.split(owned))):
            wall = np.zeros(own.shape, bool)
            if not self.grid.periodic[a]:
                wall[(slice(None),) * a + ([0, -1],)] = True
            given = ~own & ~wall & (field.mass(a) > 0.0)
            values = np.where(given, field.velocity(a), projected)
            out.append(extrapolate(values, own | wall | given, EXTRAPOLATION_LAYERS))
        u, v = out
        enforce_boundaries(u, v, self.grid)
        return u, v

    def step(self, dt: float) -> None:
        kernel = self.scheme.kernel
        sts = stencils(self.layout, self.x, kernel)
        old = p2g(self.layout, self.x, self.vel, self.m, kernel, c=self.c, sts=sts)
        self.u, self.v = self.grid_forces(old, dt)
        new = FaceField(self.u, self.v, old.mu, old.mv)
        self.vel, self.c = g2p(self.scheme, sts, new, old, self.vel)
        self.x = self.advect(dt)

    def advect(self, dt: float) -> np.ndarray:
        """The new positions (ADVECTIONS), kept in the box."""
        if self.advection == "particle":
            return self._inside(self.x + dt * self.vel)
        at = velocity_sampler(self.u, self.v, self.grid, PARTICLE_WALLS)
        mid = self._inside(self.x + 0.5 * dt * at(self.x))
        return self._inside(self.x + dt * at(mid))

    def _inside(self, x: np.ndarray) -> np.ndarray:
        size = np.array([self.grid.nx, self.grid.ny]) * self.grid.h
        for axis in (0, 1):
            if self.grid.periodic[axis]:
                x[:, axis] = np.mod(x[:, axis], size[axis])
        margin = 1e-9 * self.grid.h
        return np.clip(x, margin, size - margin)

    def observe(self) -> dict:
        pad = np.zeros((len(self.x), 1))
        return {"x": np.hstack([self.x, pad]), "v": np.hstack([self.vel, pad]),
                "grid.u": self.u.copy(), "grid.v": self.v.copy(), "grid.p": self.p.copy()}
