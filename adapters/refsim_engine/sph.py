"""The in-house engine's fluid step (`refsim`, feature "fluid"): 2D weakly compressible SPH
(`refsim.models.sph`) with a fluid block released in a tank whose walls are dummy particles
(the lattices from `refsim_adapters.common.sph_lattice`)."""
from __future__ import annotations

import numpy as np

from refsim.engine import Sim
from refsim.models.sph import WCSPH, FluidState
from refsim.scene import FluidBlock

from ..common.sph_lattice import (WALL_LAYERS, fluid_particles, hydrostatic_densities,
                                  plane_gravity, wall_particles)


class FluidSim(Sim):
    def __init__(self, scene, dt):
        fluid = scene.part(FluidBlock)
        self.dt, self.fluid = float(dt), fluid
        g = plane_gravity(scene)
        x = fluid_particles(fluid)
        rho = hydrostatic_densities(fluid, x, g)
        self.mass = fluid.density * fluid.spacing ** 2
        self.h = fluid.smoothing * fluid.spacing
        self.model = WCSPH(wall_particles(fluid), self.mass, self.h, fluid.density,
                           fluid.sound_speed, fluid.viscosity_alpha, g,
                           no_slip=fluid.no_slip, delta=fluid.delta, tension=fluid.tension)
        self.state = FluidState(x=x, v=np.zeros_like(x), rho=rho)
        self.geom, self.acc = self.model.start(self.state)

    def _step_impl(self, n):
        for _ in range(n):
            self.geom, self.acc = self.model.step(self.state, self.geom, self.acc, self.dt)

    def _observe(self):
        s = self.state
        return {"x": s.x.copy(), "v": s.v.copy(), "rho": s.rho.copy(),
                "mass": np.full(len(s.x), self.mass)}

    def settings(self):
        f = self.fluid
        return {"integrator": {"name": "velocity_verlet", "order": 2,
                               "family": "kick-drift-kick (leapfrog) with continuity density",
                               "explicit": True, "symplectic": False},
                "model": "WCSPH: Wendland C2, Tait gamma 7, Monaghan viscosity, delta-SPH "
                         "density diffusion, Adami walls",
                "smoothing_h": self.h, "h_over_dx": f.smoothing, "sound_speed": f.sound_speed,
                "viscosity_alpha": f.viscosity_alpha, "rho0": f.density,
                "delta_sph": f.delta,
                "pressure": "Tait, negative kept (tension)" if f.tension else
                "Tait, clamped at 0",
                "walls": "no-slip (viscosity on wall pairs)" if f.no_slip else
                "free-slip (pressure only)",
                "particles": len(self.state.x), "wall_particles": len(self.model.walls),
                "wall_layers": WALL_LAYERS, "neighbours": "cell list by sort, every step",
                "dtype": "float64", "threads": 1,
                "stages": ["gravity", "neighbours", "sph_rates", "walls_adami",
                           "integrate:kick-drift-kick"]}
