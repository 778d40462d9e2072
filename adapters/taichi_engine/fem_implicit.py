"""taichi's implicit steppers of a dynamic FEM mesh (issue 26): refsim.integrators.implicit's
ImplicitEuler and BaraffWitkin on the arithmetic of refsim's FemSystem (lumped masses, no
damping: the fem group builds FemSystem without Rayleigh terms), with the group's kernels:
forces and accelerations a = (f + ext) / m from `forces`, the tangent K = -df/dx from the
`stiffness` kernel (the static solve's triplets; a plastic law's tangent is its elastic
law's, as refsim's VonMises.tangent), entered as the triplets of M + h^2 K on the free dofs
into a ti.linalg.SparseMatrixBuilder (f64) and solved by ti.linalg.SparseSolver (LDLT, AMD:
Eigen's SimplicialLDLT, f64), the pattern analysed once per Sim and factorised numerically
once per step. All in the body's coordinates (the triangles' plane, or the world).

- implicit_euler (refsim's simplified Newton): v1 = v; the matrix M + h^2 K(x + h v) formed
  and factorised once per step at the predictor; then dv = (M + h^2 K)^-1 M (v1 - v -
  h a(x + h v1)), v1 -= dv, until max |dv| <= tol (1 + max |v1|) in world components
  (refsim's rule and tol, max_iter: EngineFailure past it), one iteration for the linear law
  without plasticity; x1 = x + h v1. refsim solves (I + h^2 M^-1 K) dv = residual, the same
  system divided through by M (dense LU for its small meshes): equal up to the solves'
  round-off.
- baraff_witkin: (M + h^2 K(x)) dv = h (M a(x) - h K v), K v summed by the same kernel from
  the element matrices; v1 = v + dv, x1 = x + h v1 (refsim's sparse form; its dense form for
  states under 96 dofs is the same system divided by M).
A plastic material commits its return at x1 after each step (the `commit` kernel), as
refsim's FemSystem.advance does. One Python iteration per step (and per Newton iteration):
forces kernel, assembly kernel, factorisation, solve.
"""
from __future__ import annotations

import time

import numpy as np

from refsim.engine import EngineFailure, Sim
from refsim.integrators import get_integrator
from refsim.scene import single_mesh

IMPLICIT = ("implicit_euler", "baraff_witkin")
NATIVE = {"implicit_euler": "simplified Newton on v1: (M + h^2 K(x + h v)) dv = M (v1 - v - h "
                            "a(x + h v1)), matrix formed and factorised once per step",
          "baraff_witkin": "one linear solve per step: (M + h^2 K(x)) dv = h (M a(x) - h K v)"}
SOLVER = ("the triplets of M + h^2 K (K = -df/dx from the kernel's closed-form dP/dF, the "
          "static solve's; lumped M on the diagonal) on the free dofs into "
          "ti.linalg.SparseMatrixBuilder (f64), ti.linalg.SparseSolver LDLT (Eigen "
          "SimplicialLDLT, AMD ordering, f64): pattern analysed once per Sim, one numeric "
          "factorisation per step")

# measured (taichi 1.7.4, plastic_set's one tetrahedron, 500 launches of `forces`, machine
# loaded: load average 7.7 on 2 cores): taichi's Python-side argument setup of the mesh's
# 15-field argpack dominates a launch
LAUNCH_COST = ("each kernel launch costs about 0.55 ms of Python-side argpack setup (measured "
               "on a loaded 2-core machine): on small meshes the rows' us/step are mostly the "
               "1 + Newton iterations (implicit_euler) or 2 (baraff_witkin) launches a step")


class FemImplicitSim(Sim):
    """A dynamic mesh stepped by implicit_euler or baraff_witkin (module docstring)."""

    def __init__(self, scene, dt, integrator):
        from .fem_data import FemData
        from .kernel_types import ti
        from .runtime import runtime
        rt = runtime()
        self.dt, self.integrator, self.steps = float(dt), integrator, 0
        self.stepper = get_integrator(integrator)
        t0 = time.perf_counter()
        self.data = data = FemData(single_mesh(scene), scene.gravity)
        mesh, d, n = data.mesh, data.d, data.n
        self.x = data.local(mesh.positions)
        v = np.array(mesh.velocities, float)
        v[~data.free] = 0.0
        self.v = data.local(v)
        self.free_dofs = np.repeat(data.free, d)
        size = int(self.free_dofs.sum())
        self.mass = np.repeat(data.masses()[data.free], d)
        self.inv_m = data.arrays["inv_m"].to_numpy()[:, None]
        self.ext = data.external()
        self.kw, self.zero = np.zeros(size), np.zeros((n, d))
        triplets = len(data.body.elements.cells) * ((d + 1) * d) ** 2 + size
        self.builder = ti.linalg.SparseMatrixBuilder(size, size, max_num_triplets=triplets,
                                                     dtype=ti.f64)
        self.solver = ti.linalg.SparseSolver(dtype=ti.f64, solver_type="LDLT", ordering="AMD")
        key = ("fem", d, data.law["name"], data.plane_strain, data.plastic, integrator)
        self.cold = key not in rt["compiled"]
        self.solver.analyze_pattern(self._build(self.x, self.zero))  # compiles; pattern once
        self._accel(self.x)
        if data.plastic:
            data.compile_commit(self.x)
        rt["ti"].sync()
        self.compile_s = time.perf_counter() - t0
        rt["compiled"].add(key)
        self._step = self._implicit_euler if integrator == "implicit_euler" else \
            self._baraff_witkin

    def _build(self, x, w):
        """M + h^2 K(x) built (kw = K(x) w on the free dofs)."""
        self.kw[:] = 0.0
        h = self.dt
        self.data.k.stiffness(self.data.pack, np.ascontiguousarray(x), self.builder, h * h,
                              1.0, np.ascontiguousarray(w), self.kw)
        return self.builder.build()

    def _factorise(self, x, w):
        self.solver.factorize(self._build(x, w))
        if not self.solver.info():
            raise EngineFailure(f"taichi SparseSolver LDLT could not factorise M + h^2 K "
                                f"({self.integrator})")

    def _solve(self, rhs):
        return np.asarray(self.solver.solve(np.ascontiguousarray(rhs)), dtype=np.float64)

    def _accel(self, x):
        """(n, d) a = (f + ext) / m at x, 0 on pinned nodes (the kernels' accel)."""
        return (self.data.forces(x) + self.ext) * self.inv_m

    def _world_max(self, u):
        """max |u| over world components of (n, d) local vectors (refsim's stopping norm)."""
        return float(np.abs(self.data.body.to_world(u, vectors=True)).max(initial=0.0))

    def _implicit_euler(self):
        h, x, v, free = self.dt, self.x, self.v, self.free_dofs
        tol, max_iter = self.stepper.tol, self.stepper.max_iter
        v1 = v.copy()
        self._factorise(x + h * v1, self.zero)
        linear = self.data.linear
        for _ in range(1 if linear else max_iter):
            residual = (v1 - v - h * self._accel(x + h * v1)).reshape(-1)[free]
            dv = self._solve(self.mass * residual)
            flat = v1.reshape(-1)
            flat[free] -= dv
            change = np.zeros_like(flat)
            change[free] = dv
            if linear or self._world_max(change.reshape(v.shape)) <= tol * (
                    1.0 + self._world_max(v1)):
                break
        else:
            raise EngineFailure(f"implicit_euler: Newton did not converge in {max_iter} "
                                "iterations")
        return x + h * v1, v1

    def _baraff_witkin(self):
        h, x, v, free = self.dt, self.x, self.v, self.free_dofs
        self._factorise(x, v)
        m_a = self.mass * self._accel(x).reshape(-1)[free]
        dv = self._solve(h * (m_a - h * self.kw))
        v1 = v.copy()
        v1.reshape(-1)[free] += dv
        return x + h * v1, v1

    def _step_impl(self, n):
        for _ in range(n):
            x1, v1 = self._step()
            self.x, self.v = np.ascontiguousarray(x1), np.ascontiguousarray(v1)
            if self.data.plastic:
                self.data.k.commit(self.data.pack, self.x)

    def _observe(self):
        return {"x": self.data.world(self.x), "v": self.data.world(self.v, vectors=True)}

    def settings(self):
        from .fem_data import base_settings
        described = self.stepper.describe()
        described.pop("sparse_from_state_size", None)  # refsim's dense/sparse switch
        described["solver"] = "taichi SparseSolver LDLT"
        newton = ({"newton_tol": self.stepper.tol, "newton_max_iter": self.stepper.max_iter,
                   "newton_stop": "max |dv| <= tol (1 + max |v1|), world components; one "
                                  "iteration for the linear law without plasticity"}
                  if self.integrator == "implicit_euler" else {})
        return {"integrator": {**described, "native": NATIVE[self.integrator]},
                **base_settings(self), "solver": SOLVER, **newton,
                "time_loop": "one Python iteration per step (and per Newton iteration): "
                             "forces and assembly kernels, factorisation, solve; "
                             + LAUNCH_COST}

    def close(self):
        self.builder = self.solver = self._step = None

