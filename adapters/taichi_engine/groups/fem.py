"""taichi's finite-element group (slides 001 and 000; issue 26): one P1 mesh part
(`TriangleMesh` in plane stress or plane strain, or `TetMesh`) of one material, the four laws
of refsim.models.fem.laws (linear = Cauchy as printed, green = StVK, corotated, neo_hookean =
Smith et al. 2018) as float64 kernels (`fem_kernels`, `fem_stress`): F = Ds Dm^-1, the first
Piola stress, f = -V P Dm^-T scattered into the nodes, lumped masses rho V / (d + 1) per
element node (refsim's FemSystem's), constant nodal loads and gravity; pinned nodes held at
the mesh's `positions`. Kernels work in the body's coordinates (the triangles' plane, d = 2,
or the world, d = 3); the rest shape (Dm^-1, V, the plane's basis, the law's mu, lam, alpha)
is refsim's ElasticBody's, computed once per build in numpy.

As refsim's fem group, the scene chooses:
- `scene.meta["solve"] == "static"`: only "steady", one `step()` = one complete static Newton
  solve from the initial positions. Each iteration a kernel enters the tangent K = -df/dx of
  the free dofs as triplets into a ti.linalg.SparseMatrixBuilder (f64; one directional
  derivative dP(F; dF) of the law per element dof, closed form as refsim's) and
  ti.linalg.SparseSolver(LDLT, AMD; Eigen's SimplicialLDLT, float64) solves K dx = f_int +
  f_ext, the pattern analysed once per Sim. A direct solve, not a kernel CG: it is the same
  Newton as refsim's (exact linear solves, quadratic convergence, the same iteration counts
  and the same stopping rule: max |residual| <= NEWTON_RTOL x the force scale, or an update
  under the positions' round-off, or one step for the linear law), so the two rows differ by
  the solves' round-off only; a CG would add its own stopping tolerance to every iteration.
- any other scene: explicit_euler, symplectic_euler, velocity_verlet or rk4 with refsim's
  arithmetic, the time loop inside one kernel per Sim.step(n) (serialized); implicit_euler
  and baraff_witkin (`fem_implicit`: refsim's simplified Newton and linearised step, M + h^2 K
  from the same tangent kernel, solved by the same SparseSolver LDLT, one factorisation per
  step), a Python iteration per step.
Plasticity (`fem_plastic`): refsim's von Mises radial return (ideal or linear hardening) on
the linear, green and corotated laws, tetrahedra or plane strain, per element state in the
argpack, committed after every accepted step of every stepper (refsim's FemSystem.advance);
the tangent stays the elastic law's. Refused: plasticity elsewhere (refsim has no
plane-stress return), contact, other parts. Observes x, v (n, 3) of every node (pinned ones
at their positions, v = 0), and for "steady" `residual` (max |f_int + f_ext| on the free
dofs, N) and `iterations`.
"""
from __future__ import annotations

import time

import numpy as np

from refsim.engine import EngineFailure, ModelGroup, Sim
from refsim.integrators import get_integrator
from refsim.integrators.spec import spec_name
from refsim.scene import single_mesh

from ..fem_data import FemData, base_settings
from ..kernel_store import to_taichi

EXPLICIT = ("explicit_euler", "symplectic_euler", "velocity_verlet", "rk4")
STEPPERS = EXPLICIT + ("implicit_euler", "baraff_witkin")
INTEGRATORS = ("steady",) + STEPPERS
STEADY = {"name": "steady", "order": 0, "family": "static solve (Newton)", "explicit": False,
          "symplectic": False}
NEWTON_RTOL = 1e-12  # refsim's fem group's: the static cases' bound reads it from settings
MAX_ITER = 50  # refsim's solve_static default
PLASTIC_LAWS = ("linear", "green", "corotated")  # refsim's VonMises
ROUND_OFF = 16 * np.finfo(float).eps  # an update below this x max |x| moves nothing (refsim)
NATIVE = {"explicit_euler": "kernel: x += h v; v += h a(x) (from the old state)",
          "symplectic_euler": "kernel: v += h a(x); x += h v",
          "velocity_verlet": "kernel: v += h/2 a; x += h v; a = a(x); v += h/2 a",
          "rk4": "kernel: classical 4-stage Runge-Kutta on (x, v), refsim's stage sums"}


def _mesh(scene):
    return single_mesh(scene)


def claims(scene) -> bool:
    return _mesh(scene) is not None


def supports(engine, scene, integrator):
    if scene.part_kinds() != {"meshes"}:
        return (f"taichi fem: one mesh alone, got also "
                f"{', '.join(sorted(scene.part_kinds() - {'meshes'}))}")
    mesh = _mesh(scene)
    plastic = mesh.material.plasticity
    if plastic is not None and mesh.material.strain not in PLASTIC_LAWS:
        return (f"taichi fem: von Mises plasticity on the laws {', '.join(PLASTIC_LAWS)} "
                f"(refsim's), not {mesh.material.strain}")
    if plastic is not None and getattr(mesh, "plane", "") == "stress":
        return ("taichi fem: plasticity on tetrahedra or plane strain (refsim has no "
                "plane-stress return)")
    if len(mesh.pinned) == len(mesh):
        return "taichi fem: every node is pinned (nothing moves)"
    if scene.contact is not None:
        return "taichi fem: no contact (the mesh is alone)"
    static = scene.meta.get("solve") == "static"
    name = spec_name(integrator)
    if name and static and name != "steady":
        return ("taichi fem: the scene asks for its static equilibrium (meta solve = static), "
                "solved by 'steady', not stepped by " + name)
    if name and not static and name not in STEPPERS:
        return f"taichi fem steps a dynamic scene with {', '.join(STEPPERS)}, not {name}"
    return None


class FemKernelSim(Sim):
    """A mesh stepped by one of STEPPERS, the time loop in one kernel per Sim.step(n)."""

    def __init__(self, scene, dt, integrator):
        from ..runtime import runtime
        rt = runtime()
        self.dt, self.integrator, self.steps = float(dt), integrator, 0
        t0 = time.perf_counter()
        self.data = data = FemData(_mesh(scene), scene.gravity)
        self.x = data.local(data.mesh.positions)
        v = np.array(data.mesh.velocities, float)
        v[~data.free] = 0.0
        self.v = data.local(v)
        key = ("fem", data.d, data.law["name"], data.plane_strain, data.plastic, integrator)
        self.cold = key not in rt["compiled"]
        self._prepare()
        self.advance(0)  # compiles on first use
        rt["ti"].sync()
        self.compile_s = time.perf_counter() - t0
        rt["compiled"].add(key)

    def _prepare(self):
        k, p, shape = self.data.k, self.data.pack, (self.data.n, self.data.d)
        name = self.integrator
        if name == "rk4":
            scratch = [to_taichi(np.zeros((4 * shape[0], shape[1])), k.vec) for _ in range(3)]
            self.advance = lambda n: k.rk4(p, self.x, self.v, *scratch, self.dt, n)
            return
        self.a = np.zeros(shape)  # Verlet carries a(x) between calls
        if name == "velocity_verlet":
            k.velocity_verlet(p, self.x, self.v, self.a, self.dt, 0, 1)  # a = a(x0)
            self.advance = lambda n: k.velocity_verlet(p, self.x, self.v, self.a, self.dt, n, 0)
            return
        stepper = getattr(k, name)
        self.advance = lambda n: stepper(p, self.x, self.v, self.a, self.dt, n)

    def _step_impl(self, n):
        done = 0
        while done < n:  # n is an i32 kernel argument
            chunk = min(n - done, 2 ** 31 - 1)
            self.advance(chunk)
            done += chunk

    def _observe(self):
        return {"x": self.data.world(self.x), "v": self.data.world(self.v, vectors=True)}

    def settings(self):
        described = get_integrator(self.integrator).describe()
        return {"integrator": {**described, "native": NATIVE[self.integrator]},
                **base_settings(self),
                "time_loop": "inside one kernel per Sim.step(n), ti.loop_config(serialize="
                             "True): sweeps over elements and nodes serial"}

    def close(self):
        self.advance = None


class FemStaticSim(Sim):
    """The mesh's static equilibrium, solved afresh from its initial positions every step
    (module docstring)."""

    def __init__(self, scene, dt):
        from ..kernel_types import ti
        from ..runtime import runtime
        rt = runtime()
        self.dt, self.steps = float(dt), 0
        t0 = time.perf_counter()
        self.data = data = FemData(_mesh(scene), scene.gravity)
        self.x0 = data.local(data.mesh.positions)
        self.x = self.x0.copy()
        self.loads = np.where(data.free[:, None], data.external(), 0.0)
        self.free_dofs = np.repeat(data.free, data.d)
        size = int(self.free_dofs.sum())
        triplets = len(data.body.elements.cells) * ((data.d + 1) * data.d) ** 2
        self.builder = ti.linalg.SparseMatrixBuilder(size, size, max_num_triplets=triplets,
                                                     dtype=ti.f64)
        self.solver = ti.linalg.SparseSolver(dtype=ti.f64, solver_type="LDLT", ordering="AMD")
        self.residual, self.iterations = float("nan"), 0
        self.unused = (to_taichi(np.zeros((data.n, data.d)), data.k.vec),
                       to_taichi(np.zeros(size)))  # the kernel's w, kw (no K w here)
        key = ("fem", data.d, data.law["name"], data.plane_strain, data.plastic, "steady")
        self.cold = key not in rt["compiled"]
        self.solver.analyze_pattern(self._stiffness(self.x))  # compiles; pattern found once
        data.forces(self.x)
        rt["ti"].sync()
        self.compile_s = time.perf_counter() - t0
        rt["compiled"].add(key)

    def _stiffness(self, x):
        self.data.k.stiffness(self.data.pack, x, self.builder, 1.0, 0.0, *self.unused)
        return self.builder.build()

    def _solve(self, x, rhs):
        matrix = self._stiffness(x)
        self.solver.factorize(matrix)
        if not self.solver.info():
            raise EngineFailure("taichi SparseSolver LDLT could not factorise the tangent "
                                "stiffness")
        return np.asarray(self.solver.solve(rhs), dtype=np.float64)

    def _newton(self):
        """refsim.models.fem.static's Newton loop, with the kernels' forces and tangent."""
        x, free, linear = self.x0.copy(), self.free_dofs, self.data.linear
        for iteration in range(MAX_ITER + 1):
            f_int = self.data.forces(x)
            residual = (f_int + self.loads).reshape(-1)[free]
            scale = max(np.abs(self.loads).max(initial=0.0), np.abs(f_int).max(initial=0.0))
            worst = np.abs(residual).max(initial=0.0)
            if worst <= NEWTON_RTOL * scale or scale == 0.0:
                return x, iteration, worst
            if iteration == MAX_ITER:
                break
            flat = x.reshape(-1).copy()
            dx = self._solve(x, residual)
            flat[free] += dx
            x = np.ascontiguousarray(flat.reshape(x.shape))
            if linear or np.abs(dx).max(initial=0.0) <= ROUND_OFF * np.abs(flat).max():
                return x, iteration + 1, worst
        raise EngineFailure(f"taichi fem static Newton: max |residual| {worst:.3g} N above "
                            f"{NEWTON_RTOL:g} x {scale:.3g} N after {MAX_ITER} iterations")

    def _step_impl(self, n):
        for _ in range(n):  # every step the same complete solve from the initial positions
            self.x, self.iterations, residual = self._newton()
            self.residual = float(residual)

    def _observe(self):
        return {"x": self.data.world(self.x), "v": np.zeros((self.data.n, 3)),
                "residual": self.residual, "iterations": self.iterations}

    def settings(self):
        return {"integrator": dict(STEADY), **base_settings(self), "newton_rtol": NEWTON_RTOL,
                "solver": "Newton on the free dofs: the tangent's triplets from a kernel into "
                          "ti.linalg.SparseMatrixBuilder (f64), ti.linalg.SparseSolver LDLT "
                          "(Eigen SimplicialLDLT, AMD, f64), pattern analysed once; stops at "
                          "max |residual| <= newton_rtol x the force scale, at the positions' "
                          "round-off, or after one step for the linear law (refsim's rule)",
                "step": "one complete static solve from the initial positions",
                "time_loop": "one Python iteration per Newton step (assembly kernel, solve)"}

    def close(self):
        self.builder = self.solver = None


def build(engine, scene, dt, integrator, formulation):
    if integrator == "steady":
        return FemStaticSim(scene, dt)
    if integrator not in EXPLICIT:
        from ..fem_implicit import FemImplicitSim
        return FemImplicitSim(scene, dt, integrator)
    return FemKernelSim(scene, dt, integrator)


MODEL_GROUP = ModelGroup(name="fem", build=build, claims=claims,
                         parts=frozenset({"meshes"}),
                         features=frozenset({"fem", "gravity", "plasticity"}),
                         supports=supports, integrators=INTEGRATORS)
