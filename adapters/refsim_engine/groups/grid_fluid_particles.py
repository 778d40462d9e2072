"""The in-house engine's particle-fluid group (issue 27, case 5: PIC, FLIP, the blend and APIC
on the MAC grid; refsim.models.grid_fluid.particle_fluid): a FluidGrid scene that also holds
the fluid's Particles (the module name sorts before grid_fluids, so this group claims it).

Integrators: the transfer specs "<scheme>_<kernel>[:alpha]" (refsim.models.grid_fluid.
transfer.parse_transfer): pic / flip / blend (alpha 0.95 unless given) / apic x bilinear /
quadratic_bspline. Formulations: the projection's solver (direct, cg, pyamg) to the part's
rtol. Observes x, v (n, 3) of the particles, grid.u, grid.v, grid.p, divergence, residual.
"""
from __future__ import annotations

import numpy as np

from refsim.engine import EngineFailure, ModelGroup, Sim
from refsim.models.grid_fluid.particle_fluid import ParticleFluid
from refsim.models.grid_fluid.projection import METHODS
from refsim.models.grid_fluid.transfer import TRANSFER_SPECS, parse_transfer, transfer_info
from refsim.scene import FluidGrid, Particles

INTEGRATORS = TRANSFER_SPECS  # the blends at alpha 0.95 unless named "blend_<kernel>:alpha"
FEATURES = frozenset({"fluid_grid", "gravity", "free_surface"})


def claims(scene) -> bool:
    return scene.part(FluidGrid) is not None and scene.part(Particles) is not None


def supports(engine, scene, integrator):
    if scene.part_kinds() != {"fluid_grids", "particles"} or scene.dim != 2:
        return "refsim particle fluids: one FluidGrid and its Particles, 2D"
    grid = scene.part(FluidGrid)
    if grid.nu > 0 or grid.lid != 0 or grid.marks is not None:
        return ("refsim particle fluids: inviscid, no lid, marks from the particles (the "
                "part's nu, lid and marks are not used)")
    if integrator is not None and transfer_info(integrator) is None:
        return f"refsim particle fluids: transfers {', '.join(INTEGRATORS)}, got {integrator!r}"
    return None


def formulations(engine, scene):
    return METHODS


class ParticleFluidSim(Sim):
    failures = (EngineFailure,)

    def __init__(self, scene, dt, integrator, method):
        self.dt, self.integrator = float(dt), integrator
        self.model = ParticleFluid.from_scene(scene, parse_transfer(integrator), method)

    def _step_impl(self, n):
        for _ in range(n):
            self.model.step(self.dt)
            info = self.model.info
            if not info["residual"] <= self.model.rtol:
                raise EngineFailure(f"projection ({self.model.method}) stopped at relative "
                                    f"residual {info['residual']:.3g} > rtol {self.model.rtol:g}")
            if not np.all(np.isfinite(self.model.vel)):
                raise EngineFailure("non-finite particle velocity")

    def _observe(self):
        out = self.model.observe()
        info = self.model.info or {"divergence": 0.0, "residual": 0.0}
        return {**out, "divergence": float(info["divergence"]),
                "residual": float(info["residual"])}

    def settings(self):
        m = self.model
        return {"integrator": transfer_info(self.integrator), "dtype": "float64",
                "threads": 1, "transfer": m.scheme.label, "kernel": m.scheme.kernel,
                "flip_fraction": m.scheme.flip_fraction, "particle_advection": m.advection,
                "projection": m.method, "rtol": m.rtol, "particles": len(m.x),
                "cells": [m.grid.nx, m.grid.ny], "h": m.grid.h,
                "marks": "a cell holding a particle is fluid, else air (p = 0)",
                "vectorised": "numpy bincount over particles x stencil; scipy.sparse solves"}


def build(engine, scene, dt, integrator, formulation):
    return ParticleFluidSim(scene, dt, integrator, formulation or METHODS[0])


MODEL_GROUP = ModelGroup(name="grid_fluid_particles", build=build, claims=claims, parts=None,
                         features=FEATURES, supports=supports, formulations=formulations,
                         integrators=INTEGRATORS)
