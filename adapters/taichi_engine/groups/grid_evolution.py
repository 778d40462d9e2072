"""taichi's finite-difference group: the heat equation u_t = D lap u and the wave equation
u_tt = c^2 lap u on one `Grid` part (1D, 2D or 3D; Dirichlet, Neumann or periodic sides), the
models and steppers of refsim's grid_evolution group as float64 kernels
(`refsim_adapters.taichi_engine.grid_kernels`), so the two agree to round-off.

Heat: explicit_euler (FTCS, one fused sweep u + h (D lap u) per step), midpoint, heun, rk4
(the tableaux written out), implicit_euler and crank_nicolson (taichi's SparseSolver, LU, on
I - theta h D L assembled by a kernel, factorised once per Sim). Wave: stormer_verlet (the
three-level leapfrog in its summed form, as refsim), velocity_verlet, symplectic_euler, rk4,
implicit_euler and implicit_midpoint (SparseSolver LU as above).

State: flat C-order numpy float64 arrays handed to the kernels as external arrays (arch=cpu:
zero-copy); observe() copies them into the grid's shape. Observes grid.<name> (heat) or grid.u
and grid.v (wave).
"""
from __future__ import annotations

import time

import numpy as np

from refsim_adapters.common.grid_pde import (
    evolution_group,
    field_name,
    fields_of,
    integrator_reason,
    scene_reason,
)
from refsim.engine import Sim
from refsim.integrators import get_integrator
from refsim.integrators.first_order import get_first_order
from refsim.models.grid_pde import GridPDE
from refsim.scene import Grid

from ..kernel_store import arrays_setting, to_taichi
from ..sim import I32_MAX

IMPLICIT = {"implicit_euler", "crank_nicolson", "implicit_midpoint"}
FAMILY = {"implicit_euler": "implicit Euler (taichi SparseSolver LU)",
          "crank_nicolson": "implicit trapezoidal (Crank-Nicolson, taichi SparseSolver LU)",
          "implicit_midpoint": "implicit midpoint (taichi SparseSolver LU)"}
ORDER = {"implicit_euler": 1, "crank_nicolson": 2, "implicit_midpoint": 2}
# what one step costs: passes over the grid (a sweep: the Laplacian at every point) and, for
# the implicit schemes, kernel launches from Python around the solve
LOOP = "; no launch per step (the time loop is inside the one kernel of Sim.step(n))"
PER_STEP = {"explicit_euler": "1 fused sweep u + h (D lap u) into the other buffer" + LOOP,
            "midpoint": "2 stage passes + 2 sweeps + 1 update pass" + LOOP,
            "heun": "2 stage passes + 2 sweeps + 1 update pass" + LOOP,
            "rk4": "4 stage passes + 4 sweeps + 1 update pass" + LOOP,
            "symplectic_euler": "1 sweep (v += h c^2 lap u) + 1 pass (u += h v)" + LOOP,
            "stormer_verlet": "1 sweep (d += h^2 c^2 lap u) + 1 pass (u += d)" + LOOP,
            "velocity_verlet": "2 passes + 1 sweep (a = c^2 lap u)" + LOOP,
            "implicit_euler": "1 LU solve; heat: no kernel launch; wave: 2 launches (rhs "
                              "u + h v; v += h c^2 lap u1)",
            "crank_nicolson": "1 launch (rhs u + h/2 D lap u) + 1 LU solve",
            "implicit_midpoint": "1 launch (ax, rhs) + 1 LU solve + 1 launch (v update)"}
SOLVER_SETTING = ("ti.linalg.SparseSolver(dtype=f64, solver_type='LU') (Eigen SparseLU) of "
                  "I - c h^k lap assembled by a taichi kernel into a SparseMatrixBuilder, "
                  "analysed and factorised once per Sim; solve() takes and returns numpy f64")


def supports(engine, scene, integrator):
    reason = scene_reason(scene, "taichi")
    return reason or integrator_reason(scene.parts_of(Grid)[0], integrator)


def kernel(key, make):
    """A kernel made once per process (runtime()["kernels"]); (kernel, cold)."""
    from ..runtime import runtime
    made = runtime()["kernels"]
    cold = key not in made
    if cold:
        made[key] = make()
    return made[key], cold


def describe(name, first_order):
    if name in IMPLICIT:
        return {"name": name, "order": ORDER[name], "family": FAMILY[name], "explicit": False,
                "symplectic": name == "implicit_midpoint"}
    return (get_first_order(name) if first_order else get_integrator(name)).describe()


class GridSim(Sim):
    """What the heat and wave Sims share: geometry, the factorised solver, chunked stepping,
    settings. Subclasses set `arrays` (the numpy state) and `_advance(n)`."""

    def __init__(self, grid, dt, integrator):
        from .. import grid_kernels as gk
        from ..runtime import runtime
        self.rt, self.gk = runtime(), gk
        self.grid, self.dt, self.integrator, self.steps = grid, float(dt), integrator, 0
        self.system = GridPDE(grid)
        self.coef = float(self.system.factor)
        self.ndim, self.size = len(grid.shape), int(np.prod(grid.shape))
        self.geo = gk.geometry(grid.shape, grid.spacing, grid.boundary)
        self.solver, self.cold = None, False
        self.zeros = np.zeros(self.size)

    def flat(self, arr):
        return np.array(arr, dtype=np.float64, order="C").reshape(-1)

    def compiled(self, *calls):
        """Run the first (compiling) calls, timed as compile_s."""
        t0 = time.perf_counter()
        for call in calls:
            call()
        self.rt["ti"].sync()
        self.compile_s = time.perf_counter() - t0

    def factorise(self, c):
        """SparseSolver LU of I - c lap, once per Sim."""
        ti = self.rt["ti"]
        assemble, cold = kernel(("grid_assemble", self.ndim), lambda: self.gk.assemble_kernel(
            self.ndim))
        builder = ti.linalg.SparseMatrixBuilder(self.size, self.size, dtype=ti.f64,
                                                max_num_triplets=self.size * (1 + 3 * self.ndim))
        t0 = time.perf_counter()
        assemble(builder, self.geo, float(c), self.zeros)
        self.compile_s += (time.perf_counter() - t0) if cold else 0.0
        matrix = builder.build()
        self.solver = ti.linalg.SparseSolver(dtype=ti.f64, solver_type="LU")
        self.solver.analyze_pattern(matrix)
        self.solver.factorize(matrix)
        if not self.solver.info():
            raise ValueError(f"taichi SparseSolver could not factorise I - {c:g} lap "
                             f"(grid {self.grid.shape})")

    def solve(self, rhs):
        return np.asarray(self.solver.solve(rhs), dtype=np.float64)

    def _step_impl(self, n):
        if self.integrator in IMPLICIT:
            for _ in range(n):
                self._implicit_step()
            return
        done = 0
        while done < n:  # n is an i32 kernel argument
            chunk = min(n - done, I32_MAX)
            self._advance(chunk)
            done += chunk

    def common_settings(self, first_order):
        from ..runtime import THREADS, effective_config
        return {"integrator": describe(self.integrator, first_order), "dtype": "float64",
                "threads": THREADS, **effective_config(), "model": self.system.describe(),
                "points": self.size, "kernels_per_step": PER_STEP[self.integrator],
                "solve": SOLVER_SETTING if self.integrator in IMPLICIT else "none (explicit)",
                "layout": "flat C-order arrays, neighbours at p -+ stride (runtime strides: one "
                          "kernel per scheme and number of axes, no recompilation per shape)",
                "sweep": "interior rows without branches + boundary points with a branch per "
                         "side (Dirichlet fixed, Neumann mirrored ghost, periodic wrap)",
                "time_loop": ("one Python iteration per step (solve between launches)"
                              if self.integrator in IMPLICIT else
                              "inside one kernel per Sim.step(n), ti.loop_config(serialize="
                              "True): sweeps serial"),
                "arrays": arrays_setting(*self.arrays),
                "compile": "cold JIT in this build" if self.cold else
                "kernels already compiled in this process (launch time only)"}

    def close(self):
        self.solver = None


class HeatSim(GridSim):
    """u' = D lap u: FTCS, explicit tableaux or a theta-method by LU."""

    arrays = ("u",)

    def __init__(self, grid, dt, integrator):
        super().__init__(grid, dt, integrator)
        gk, nd, name = self.gk, self.ndim, integrator
        self.name = field_name(grid)
        self.u = self.flat(fields_of(grid)[0])
        if name == "explicit_euler":
            self.w = self.u.copy()
            self.advance, self.cold = kernel(("grid_ftcs", nd), lambda: gk.ftcs_kernel(nd))
            self.compiled(lambda: self.advance(self.u, self.w, self.geo, self.dt, self.coef, 0))
        elif name in IMPLICIT:
            (self.rhs, _), self.cold = kernel(("grid_implicit", nd),
                                              lambda: gk.implicit_kernels(nd))
            self.buffer = np.zeros(self.size)
            self.compiled(lambda: self.rhs(self.buffer, self.u, self.zeros, self.zeros,
                                           self.geo, self.dt, self.coef, 0))
            self.factorise((1.0 if name == "implicit_euler" else 0.5) * self.dt * self.coef)
        else:
            tab, stages = gk.tableau_array(get_first_order(name).tableau)
            self.advance, self.cold = kernel(("grid_heat_rk", nd), lambda: gk.heat_rk_kernel(nd))
            self.kernel_args = (to_taichi(np.zeros(self.size)),
                                to_taichi(np.zeros(stages * self.size)), to_taichi(tab), stages)
            self.compiled(lambda: self._advance(0))

    def _advance(self, n):
        if self.integrator == "explicit_euler":
            self.advance(self.u, self.w, self.geo, self.dt, self.coef, n)
            if n % 2:
                self.u, self.w = self.w, self.u
        else:
            self.advance(self.u, *self.kernel_args, self.geo, self.dt, self.coef, n)

    def _implicit_step(self):
        if self.integrator == "implicit_euler":
            self.u = self.solve(self.u)
            return
        self.rhs(self.buffer, self.u, self.zeros, self.zeros, self.geo, self.dt, self.coef, 0)
        self.u = self.solve(self.buffer)

    def _observe(self):
        return {f"grid.{self.name}": self.u.reshape(self.grid.shape).copy()}

    def settings(self):
        return self.common_settings(first_order=True)


class WaveSim(GridSim):
    """u'' = c^2 lap u on (x, v): Verlet family, RK4, or implicit Euler / midpoint by LU."""

    arrays = ("u", "v")

    def __init__(self, grid, dt, integrator):
        super().__init__(grid, dt, integrator)
        u0, v0 = fields_of(grid)
        self.x, self.v = self.flat(u0), self.flat(v0)
        self.apply, cold = kernel(("grid_laplacian", self.ndim),
                                  lambda: self.gk.laplacian_kernel(self.ndim))
        t0 = time.perf_counter()
        a0 = self.accel(self.x)  # compiles the Laplacian on first use
        extra = time.perf_counter() - t0 if cold else 0.0
        if integrator in IMPLICIT:
            self._build_implicit()
        elif integrator == "rk4":
            self._build_rk4()
        else:
            self._build_verlet(a0)
        self.compile_s += extra

    def accel(self, x):
        """c^2 lap x (0 + 1 (c^2 lap x): exactly the product)."""
        out = np.zeros(self.size)
        self.apply(out, self.zeros, x, self.geo, 1.0, self.coef)
        return out

    def _build_verlet(self, a0):
        name, nd, h = self.integrator, self.ndim, self.dt
        self.advance, self.cold = kernel(("grid_wave", nd, name),
                                         lambda: self.gk.wave_kernel(nd, name))
        # Stormer-Verlet carries d_0 = h v0 - (h^2/2) a0 (refsim's start), velocity Verlet a0
        self.aux = {"stormer_verlet": h * self.v - (0.5 * h * h) * a0,
                    "velocity_verlet": a0}.get(name, np.zeros(self.size))
        self.kernel_args = (self.aux,)
        self.compiled(lambda: self._advance(0))

    def _build_rk4(self):
        nd, gk = self.ndim, self.gk
        tab, stages = gk.tableau_array(get_integrator("rk4").tableau)
        self.advance, self.cold = kernel(("grid_wave_rk", nd), lambda: gk.wave_rk_kernel(nd))
        self.kernel_args = (to_taichi(np.zeros(self.size)),
                            *(to_taichi(np.zeros(stages * self.size)) for _ in range(2)),
                            to_taichi(tab), stages)
        self.compiled(lambda: self._advance(0))

    def _build_implicit(self):
        nd, h = self.ndim, self.dt
        (self.rhs, self.update), self.cold = kernel(("grid_implicit", nd),
                                                    lambda: self.gk.implicit_kernels(nd))
        self.mode = 1 if self.integrator == "implicit_euler" else 2
        self.buffer, self.ax, self.a1 = (np.zeros(self.size) for _ in range(3))
        self.compiled(lambda: self.rhs(self.buffer, self.x, self.v, self.ax, self.geo, h,
                                       self.coef, self.mode),
                      lambda: self.update(self.buffer, self.x, self.ax, self.a1, self.geo, 0.0,
                                          self.coef, self.mode))
        self.factorise((1.0 if self.mode == 1 else 0.25) * h * h * self.coef)

    def _advance(self, n):
        self.advance(self.x, self.v, *self.kernel_args, self.geo, self.dt, self.coef, n)

    def _implicit_step(self):
        h = self.dt
        self.rhs(self.buffer, self.x, self.v, self.ax, self.geo, h, self.coef, self.mode)
        x1 = self.solve(self.buffer)
        self.update(self.v, x1, self.ax, self.a1, self.geo, h, self.coef, self.mode)
        self.x = x1

    def velocity(self):
        """Synchronised v: Stormer-Verlet's d/h + (h/2) a(x) (refsim's output), else v."""
        if self.integrator != "stormer_verlet":
            return self.v
        h = self.dt
        return self.aux / h + (0.5 * h) * self.accel(self.x)

    def _observe(self):
        shape = self.grid.shape
        return {"grid.u": self.x.reshape(shape).copy(),
                "grid.v": np.array(self.velocity(), float).reshape(shape)}

    def settings(self):
        out = self.common_settings(first_order=False)
        if self.integrator == "stormer_verlet":
            out["observed_v"] = "d/h + (h/2) c^2 lap u (kernel) from the carried d = u_n - u_n-1"
        return out


MODEL_GROUP = evolution_group(HeatSim, WaveSim, supports)
