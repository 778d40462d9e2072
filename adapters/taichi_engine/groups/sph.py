"""taichi's sph group: 2D weakly compressible SPH (feature "fluid"; velocity_verlet only),
refsim's model (`refsim.models.sph`: Wendland C2, Tait gamma 7, Monaghan viscosity, delta-SPH
density diffusion, Adami 2012 wall particles, negative pressures clamped to 0 or kept) and
refsim's kick-drift-kick step with the trapezoid density drift, as taichi kernels (sph_physics,
sph_kernels). Particles, wall particles and initial densities come from the functions the
in-house engine uses too (`refsim_adapters.common.sph_lattice`), so both engines start from the
same bits.

Claims scenes holding a fluid block (FluidBlock). Formulations: "" (the serial kernel, its time
loop inside one launch) and "parallel" (one launch per step of a kernel whose stages are
multi-threaded loops: gathers, no atomics, the same bits). On one thread `parallel` is the
serial kernel's arithmetic: the engine leaves it out of `refsim run`'s matrix then
(TaichiEngine.matrix_formulations). Refused, with the reason: contacts (or bodies, springs,
joints) beside the fluid; linear drag; any stepper but velocity_verlet.
"""
from __future__ import annotations

import time

import numpy as np

from refsim.engine import ModelGroup
from refsim.scene import FluidBlock

from ...common.checks import linear_drag
from ...common.sph_lattice import (WALL_LAYERS, fluid_particles, hydrostatic_densities,
                                   plane_gravity, wall_particles)
from ..engine import WHO
from ..kernel_store import EXTERNAL_LAUNCH_COST, observed, to_ndarray, to_taichi
from ..runtime import THREADS, runtime
from ..sim import INTEGRATORS, KernelSim, checked_integrator

# the parts and features the engine's checks let through to the sentences below: drag and
# contacts are refused there with the reason; a Walls part beside the fluid passes, as it did
# before this group, and is not modelled (the tank's walls are the fluid's own)
PARTS = frozenset({"fluid", "walls"})
FEATURES = frozenset({"fluid", "walls", "gravity", "drag", "contacts"})
# No launch_per_step. One launch (~30 us, docs/engine_notes.md#taichi-kernel-launch-cost) is
# under 1 % of a WCSPH step (~3 ms at res20 on one thread): the formulation cannot show its
# point there, and its two reference-dt rows cost 27 s of the default run's work. The serial
# kernel and `parallel`.
FORMULATIONS = ("", "parallel")
SPH_CELLS_PER_PARTICLE = 4  # SPH grid array size 4 N + 64 (the cell grows past 2h to fit)
SPH_STATS = ("steps_without_grid", "steps")  # the kernels' counters, in `stats` order
HOST_SPH_ARRAYS = ("rho", "stats")  # read by Python: numpy (the rest: taichi ndarrays)


def claims(scene) -> bool:
    """A scene holding a fluid block."""
    return scene.part(FluidBlock) is not None


def supports(engine, scene, integrator):
    """Why a fluid scene cannot be simulated faithfully here, or None."""
    if scene.contact is not None:  # (a scene holds no bodies beside a fluid: one moving kind)
        return ("taichi adapter: a fluid scene holds the fluid and its tank only (bodies, "
                "springs, joints or contacts with SPH are not modelled)")
    reason = linear_drag(scene, WHO, "SPH particles")
    if reason:
        return reason
    if integrator is not None and integrator != "velocity_verlet":
        return ("taichi adapter: fluid scenes step with kick-drift-kick SPH "
                "('velocity_verlet'), as refsim's")
    return None


def formulations(engine, scene):
    return FORMULATIONS


def build(engine, scene, dt, integrator, formulation):
    checked_integrator(integrator)
    return FluidSim(scene.part(FluidBlock), plane_gravity(scene), dt, integrator, formulation)


class FluidSim(KernelSim):
    """Fluid particles then wall particles in one (x, v) pair of (n, 2) numpy arrays; density,
    pressure, rates, the grid and counters in the `sph_t` argpack."""

    system = "sph"
    host_arrays = ("x", "v") + HOST_SPH_ARRAYS

    def __init__(self, fluid, gravity, dt, integrator, formulation):
        from ..sph_kernels import sph_t, vec2
        self.fluid, self.gravity = fluid, gravity
        x, walls = fluid_particles(fluid), wall_particles(fluid)
        rho = hydrostatic_densities(fluid, x, self.gravity)
        self.n_fluid, self.n_wall, self.wall_layers = len(x), len(walls), WALL_LAYERS
        self.mass = fluid.density * fluid.spacing ** 2
        self.h = fluid.smoothing * fluid.spacing
        self.cells = SPH_CELLS_PER_PARTICLE * (self.n_fluid + self.n_wall) + 64
        self.nd = {key: (to_ndarray if key in HOST_SPH_ARRAYS else to_taichi)(arr)
                   for key, arr in self._arrays(rho).items()}
        self.x = to_ndarray(np.concatenate([x, walls]))
        self.v = to_ndarray(np.zeros((self.n_fluid + self.n_wall, 2)))
        pack = sph_t(n_fluid=self.n_fluid, no_slip=int(fluid.no_slip),
                     tension=int(fluid.tension), mass=self.mass, h=self.h,
                     rho0=fluid.density, c0=fluid.sound_speed,
                     alpha=fluid.viscosity_alpha, delta=fluid.delta,
                     gravity=vec2(*self.gravity), cell_min=self.cell_min(self.h), **self.nd)
        super().__init__(dt, integrator, formulation, (self.x, self.v, pack))
        if formulation == "parallel":
            self._compile_parallel()

    def _arrays(self, rho) -> dict:
        """Densities (walls at rho0), pressures, rates, accelerations, grid scratch, counters."""
        total = self.n_fluid + self.n_wall
        return {"rho": np.concatenate([rho, np.full(self.n_wall, self.fluid.density)]),
                "p": np.zeros(total), "drho": np.zeros(self.n_fluid),
                "diffused": np.zeros(self.n_fluid),
                "acc": np.zeros((self.n_fluid, 2)),
                "cell_count": np.zeros(self.cells, np.int32),
                "cell_start": np.zeros(self.cells, np.int32),
                "cell_of": np.zeros(total, np.int32), "order": np.zeros(total, np.int32),
                "grid": np.zeros(3), "dims": np.zeros(2, np.int32),
                "stats": np.zeros(len(SPH_STATS), np.int64)}

    def _compile_parallel(self):
        """The `parallel` formulation: one launch per step of a kernel whose stages are top-level
        (multi-threaded) loops. Its first launch compiles; it is made here with dt = 0, a
        no-op on the state (v, x, rho unchanged; a and the grid recomputed from the same
        state by the same functions, so the same bits), and timed into compile_s."""
        from ..sph_kernels import advance_sph_parallel, step_sph_parallel
        rt = runtime()
        key = ("sph", "parallel")
        t0 = time.perf_counter()
        step_sph_parallel(*self.args, 0.0)
        rt["ti"].sync()
        self.compile_s += time.perf_counter() - t0
        self.cold = self.cold or key not in rt["compiled"]
        rt["compiled"].add(key)
        self.nd["stats"][:] = 0
        self.advance = advance_sph_parallel

    def _thread_settings(self, base) -> dict:
        if self.variant != "parallel":
            return {"threads_used": 1,
                    "threads_note": "taichi parallelises only a kernel's outermost loop; here "
                                    "it is the serialised time loop, so the SPH kernel uses "
                                    "one thread whatever cpu_max_num_threads is"}
        return {"threads_used": base["cpu_max_num_threads"],
                "time_loop": "one launch per step from Python; each stage a top-level loop "
                             "run on cpu_max_num_threads threads (counting sort serial)",
                "per_step_python_call": "one kernel launch per step (part of step_s), with "
                                        f"{len(self.host_arrays)} numpy external arrays: "
                                        f"{EXTERNAL_LAUNCH_COST}",
                "threads_note": "stages gather per particle (no atomics), so results are "
                                "bit-identical to the serial kernel at any thread count; "
                                "the process pins cpu_max_num_threads at ti.init "
                                f"(THREADS = {THREADS} in this adapter)"}

    @staticmethod
    def cell_min(h) -> float:
        """Grid cell: the kernel support 2h, widened by 1e-12 so that the rounding of
        (x - lo) / c never puts a pair closer than 2h two cells apart."""
        return 2.0 * h * (1.0 + 1e-12)

    def _step_impl(self, n):
        super()._step_impl(n)
        if self.sph_stats()["steps_without_grid"]:
            self.failure = f"non-finite particle positions by t={self.time_after(n):.6g}"

    def sph_stats(self) -> dict:
        return dict(zip(SPH_STATS, (int(c) for c in self.nd["stats"])))

    def _observe(self):
        n = self.n_fluid
        return {"x": observed(self.x[:n]), "v": observed(self.v[:n]),
                "rho": observed(self.nd["rho"][:n]), "mass": np.full(n, self.mass)}

    def settings(self):
        f = self.fluid
        base = self.base_settings()
        integ = {"name": "velocity_verlet", "order": 2,
                 "family": "kick-drift-kick (leapfrog) with continuity density",
                 "explicit": True, "symplectic": False,
                 "native": "kernel advance_sph: v += h/2 a(x, rho); D0 = D(x, v); "
                           "Dd = D_delta(x, rho); x += h v; rho += h/2 (D0 + D(x', v)) + h Dd; "
                           "v += h/2 a(x', rho')"}
        return {**base, "integrator": integ,
                "model": "WCSPH: Wendland C2, Tait gamma 7, Monaghan viscosity, delta-SPH "
                         "density diffusion, Adami walls",
                "model_source": "refsim.models.sph (same expressions, same operation order)",
                "delta_sph": f.delta,
                "pressure": "Tait, negative kept (tension)" if f.tension else
                "Tait, clamped at 0",
                "smoothing_h": self.h, "h_over_dx": f.smoothing, "sound_speed": f.sound_speed,
                "viscosity_alpha": f.viscosity_alpha, "rho0": f.density,
                "walls": "no-slip (viscosity on wall pairs)" if f.no_slip else
                "free-slip (pressure only)",
                "gravity_2d": self.gravity.tolist(),
                "particles": self.n_fluid, "wall_particles": self.n_wall,
                "wall_layers": self.wall_layers,
                "initial_conditions": "refsim_adapters.common.sph_lattice fluid_particles / "
                                      "wall_particles, hydrostatic Tait density (identical "
                                      "to refsim's)",
                "neighbours": "uniform grid over the bounding box, cell 2h (enlarged to fit "
                              f"{SPH_CELLS_PER_PARTICLE} N + 64 cells), serial counting sort, "
                              "every step; 3 x 3 cells gathered per particle",
                "pair_sums": "gathered by each particle over its own neighbours (no atomics, "
                             "no scatter): fluid-fluid and fluid-wall, wall-wall never",
                "determinism": "bit-reproducible: each sum gathered by its particle in a "
                               "fixed order (no atomics), counting sort serial; differs from "
                               "refsim's numpy engine in summation order only",
                **self._thread_settings(base),
                "stages": ["gravity", "neighbours", "sph_rates", "walls_adami",
                           "integrate:kick-drift-kick"]}


MODEL_GROUP = ModelGroup(name="sph", build=build, claims=claims, parts=PARTS, features=FEATURES,
                         supports=supports, formulations=formulations, integrators=INTEGRATORS)
