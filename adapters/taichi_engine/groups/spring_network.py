"""taichi's spring-network group (cloth, rope, hair: one `SpringNetwork` part): the model of
refsim.models.spring_network (stretch springs with damping along the edge, air drag, gravity,
pinned nodes) as float64 kernels (`refsim_adapters.taichi_engine.network_kernels`), stepped by the
four steppers of NETWORK_INTEGRATORS with refsim's arithmetic, so the two agree to round-off:

- symplectic_euler, velocity_verlet, rk4: the time loop inside one kernel per Sim.step(n);
- baraff_witkin: (M - h D - h^2 K) dv = h (f + h K v), v += dv, x += h v, one Python iteration
  per step. Formulation "": a kernel enters the triplets into a ti.linalg.SparseMatrixBuilder
  (f64), and ti.linalg.SparseSolver(solver_type="LDLT", ordering="AMD") (Eigen's
  SimplicialLDLT: the matrix is symmetric) factorises it every step (K changes); the pattern
  is analysed once per Sim. Formulation "cg": taichi-kernel conjugate gradient, matrix-free
  over the per-spring 3x3 blocks, from dv = 0 to |r| < CG_RTOL |b| (scipy's test, the rtol of
  refsim's "cg"), all iterations in one kernel launch. Offered where refsim offers its "cg"
  (a state of SPARSE_MIN entries or more), so the two rows pair up.

Hinge and dihedral (bending) terms (refsim.models.bending's formulas, in its operation order):
kernels of `refsim_adapters.taichi_engine.bending_kernels` for the three explicit steppers, a kernel
family of their own (a network without them compiles the stretch-only kernels as before).
Baraff-Witkin refuses them: its kernels assemble the stretch springs' 3x3 blocks only (the
hinge and dihedral Hessian blocks are not assembled on taichi).
State: the free nodes' x, v as (n_free, 3) numpy arrays handed to the kernels as external
arrays; observes x and v of every node (pinned ones at their fixed positions, v = 0).
"""
from __future__ import annotations

import time

import numpy as np

from refsim_adapters.common.spring_network import (
    NETWORK_INTEGRATORS,
    claims,
    free_mask,
    integrator_reason,
    observation,
    scene_reason,
    solve_formulations,
)
from refsim.engine import EngineFailure, ModelGroup, Sim
from refsim.integrators import get_integrator
from refsim.models.spring_network import stretch_springs
from refsim.scene import SpringNetwork

from ..kernel_store import arrays_setting, to_taichi

CG_RTOL = 1e-10  # the relative residual of refsim's "cg" (the two formulations pair up)
CG_MAXITER_PER_DOF = 10  # scipy's default cap, 10 x the size of the system
FORMULATIONS = {"": "sparse direct: ti.linalg.SparseSolver LDLT (Eigen SimplicialLDLT, AMD "
                    "ordering), pattern analysed once per Sim, factorised every step",
                "cg": f"conjugate gradient in a taichi kernel, matrix-free over the spring "
                      f"blocks, from dv = 0 to |r| < {CG_RTOL:g} |b| (scipy's test, atol 0), "
                      f"at most {CG_MAXITER_PER_DOF} x 3 n_free iterations"}
NATIVE = {"symplectic_euler": "kernel: a(x, v); v += h a; x += h v",
          "velocity_verlet": "kernel: vh = v + h/2 a; x += h vh; a = a(x, vh); v = vh + h/2 a "
                             "(once more with a(x, v) when forces depend on v)",
          "rk4": "kernel: classical 4-stage Runge-Kutta on (x, v), refsim's stage sums",
          "baraff_witkin": "kernel: f, rhs = h (f + h K v), blocks of M - h D - h^2 K; "
                           "solve; v += dv, x += h v (numpy, in place)"}


def supports(engine, scene, integrator):
    reason = scene_reason(scene, "taichi") or integrator_reason(integrator)
    if reason:
        return reason
    net = scene.parts_of(SpringNetwork)[0]
    if (len(net.hinges) or len(net.dihedrals)) and integrator == "baraff_witkin":
        return ("taichi spring networks: baraff_witkin assembles the stretch springs' blocks "
                "only (the hinge and dihedral Hessian blocks are not assembled on taichi); "
                "bending runs with the explicit steppers")
    if not free_mask(net).any():
        return "taichi spring networks: every node is pinned (nothing moves)"
    return None


def formulations(engine, scene):
    return solve_formulations(scene)


def term_fields(net, free, tuples, stiffness, rest_angle, prefix):
    """One bending term's kernel fields: per tuple corner (flat) the free index or -1 and the
    fixed position; per tuple k and theta0. An absent term gets one unread placeholder entry
    (taichi has no empty ndarray; its kernel family compiles no code for the term)."""
    tuples = np.asarray(tuples, int)
    count, corners = len(tuples), tuples.reshape(-1)
    index = np.where(free, np.cumsum(free) - 1, -1)
    node, anchor = index[corners], np.asarray(net.positions, float)[corners]
    k = np.broadcast_to(np.asarray(stiffness if count else 0.0, float), count)
    theta0 = np.broadcast_to(np.asarray(rest_angle if count else 0.0, float), count)
    if not count:
        node, anchor, k, theta0 = np.full(1, -1), np.zeros((1, 3)), np.zeros(1), np.zeros(1)
    return {f"{prefix}_node": to_taichi(node.astype(np.int32)),
            f"{prefix}_anchor": to_taichi(anchor.reshape(-1, 3)),
            f"{prefix}_k": to_taichi(k), f"{prefix}_theta0": to_taichi(theta0)}


def bending_fields(net, free):
    """The bending fields of `bending_kernels.bent_t` and the per-node scratch sum."""
    return {**term_fields(net, free, np.reshape(net.hinges, (-1, 3)), net.hinge_stiffness,
                          net.hinge_rest_angle, "h"),
            **term_fields(net, free, np.reshape(net.dihedrals, (-1, 4)),
                          net.dihedral_stiffness, net.dihedral_rest_angle, "d"),
            "bend": to_taichi(np.zeros((int(free.sum()), 3)))}


def network_pack(net, gravity, drag):
    """The kernels' argpack of a network on its free nodes (and the free mask): net_t, or
    bending_kernels.bent_t when the network has hinges or dihedrals."""
    from ..kernel_types import vec3
    from ..network_kernels import net_t
    free = free_mask(net)
    springs, _ = stretch_springs(net)
    mass = np.asarray(net.masses, float)[free]
    damped = bool(springs.damping.any())
    arrays = {"mass": to_taichi(mass), "inv_m": to_taichi(1.0 / mass),
              "body": to_taichi(springs.body.astype(np.int32)),
              "other": to_taichi(springs.other.astype(np.int32)),
              "anchor": to_taichi(np.asarray(springs.anchor, float).reshape(-1, 3)),
              "k": to_taichi(springs.stiffness), "rest": to_taichi(springs.rest),
              "c": to_taichi(springs.damping)}
    scalars = {"gravity": vec3(*np.asarray(gravity, float)), "drag": float(drag),
               "damped": int(damped), "velocity_dependent": int(damped or drag > 0)}
    if len(net.hinges) or len(net.dihedrals):
        from ..bending_kernels import bent_t
        arrays.update(bending_fields(net, free))
        rested = int(bool(np.any(np.asarray(net.hinge_rest_angle) != 0)))
        return bent_t(**arrays, **scalars, h_rested=rested), arrays, free, len(springs.body)
    pack = net_t(**arrays, **scalars)
    return pack, arrays, free, len(springs.body)


class NetworkSim(Sim):
    """One spring network stepped by taichi kernels (see the module doc)."""

    def __init__(self, scene, dt, integrator, variant):
        from .. import network_kernels as nk
        from ..runtime import runtime
        self.nk, self.rt = nk, runtime()
        self.dt, self.integrator, self.variant, self.steps = float(dt), integrator, variant, 0
        self.net = net = scene.parts_of(SpringNetwork)[0]
        self.pack, self._arrays, self.free, self.n_springs = network_pack(
            net, scene.gravity, scene.linear_drag)
        self.x = np.ascontiguousarray(net.positions[self.free], dtype=np.float64)
        self.v = np.ascontiguousarray(net.velocities[self.free], dtype=np.float64)
        self.n_free = len(self.x)
        self.bending = (bool(len(net.hinges)), bool(len(net.dihedrals)))
        self.stepper_kernels = _stepper_kernels(nk, self.bending)
        key = ("network", integrator, variant) + self.bending
        self.cold = key not in self.rt["compiled"]
        t0 = time.perf_counter()
        self._prepare()
        self.rt["ti"].sync()
        self.compile_s = time.perf_counter() - t0
        self.rt["compiled"].add(key)

    def _scratch(self, count, shape=(3,)):
        return [to_taichi(np.zeros((self.n_free,) + shape)) for _ in range(count)]

    def _prepare(self):
        """Scratch arrays and the first (compiling) calls of the stepper's kernels."""
        name = self.integrator
        start, symplectic_euler, velocity_verlet, rk4 = self.stepper_kernels
        if name == "symplectic_euler":
            self.a = to_taichi(np.zeros((self.n_free, 3)))
            self.advance = lambda n: symplectic_euler(self.pack, self.x, self.v, self.a,
                                                         self.dt, n)
        elif name == "velocity_verlet":
            self.a = np.zeros((self.n_free, 3))  # carried between calls: a(x0, v0) first
            start(self.pack, self.x, self.v, self.a)
            vh, w = self._scratch(2)
            self.advance = lambda n: velocity_verlet(self.pack, self.x, self.v, self.a, vh,
                                                        w, self.dt, n)
        elif name == "rk4":
            scratch = [to_taichi(np.zeros((4 * self.n_free, 3))) for _ in range(3)]
            self.advance = lambda n: rk4(self.pack, self.x, self.v, *scratch, self.dt, n)
        else:
            self.bw = BaraffWitkinSolve(self)
            return
        self.advance(0)

    def _step_impl(self, n):
        if self.integrator != "baraff_witkin":
            done = 0
            while done < n:  # n is an i32 kernel argument
                chunk = min(n - done, 2 ** 31 - 1)
                self.advance(chunk)
                done += chunk
            return
        for _ in range(n):
            self.v += self.bw.velocity_change().reshape(-1, 3)
            self.x += self.dt * self.v

    def _observe(self):
        x = np.array(self.net.positions, float)
        v = np.zeros_like(x)
        x[self.free], v[self.free] = self.x, self.v
        return observation(x, v)

    def settings(self):
        from ..runtime import THREADS, effective_config
        integrator = get_integrator(self.integrator).describe()
        out = {"integrator": {**integrator, "native": NATIVE[self.integrator]},
               "dtype": "float64", "threads": THREADS, **effective_config(),
               "model": {"nodes": len(self.net), "free_nodes": self.n_free,
                         "pinned": len(self.net.pinned), "stretch_edges": self.n_springs,
                         "hinges": len(self.net.hinges), "dihedrals": len(self.net.dihedrals),
                         "terms": ["stretch"] + [term for term, on in
                                                 zip(("hinge", "dihedral"), self.bending) if on],
                         "edge_to_pinned_node": "spring to a fixed anchor"},
               "time_loop": ("one Python iteration per step (a solve between launches)"
                             if self.integrator == "baraff_witkin" else
                             "inside one kernel per Sim.step(n), ti.loop_config(serialize="
                             "True): sweeps over springs and nodes serial"),
               "force_sums": "per node in two passes (body ends, then other ends)",
               "arrays": arrays_setting("x", "v"),
               "compile": "cold JIT in this build" if self.cold else
               "kernels already compiled in this process (launch time only)",
               "solve": "none (explicit)" if self.integrator != "baraff_witkin"
               else FORMULATIONS[self.variant], "formulation": FORMULATIONS[self.variant]}
        if any(self.bending):
            out["bending"] = ("refsim.models.bending's forces in its operation order (hinge: "
                              "F'(c) grad c with 1/sinc; dihedral: Bridson et al. 2003's "
                              "gradient), each term's per-node sums in tuple order, added after "
                              "the stretch and drag forces; bending_kernels family "
                              f"(hinges, dihedrals) = {self.bending}")
        if self.integrator == "baraff_witkin":
            out["bw_jacobians"] = ("K_s = -k ((1 - L0/|d|) I + (L0/|d|) u u^T), D_s = -c u u^T "
                                   "(damping direction's x-derivative left out, as refsim)")
            if self.variant == "cg":
                out["cg_rtol"] = CG_RTOL
                out["cg_iterations_last_step"] = self.bw.iterations
        return out

    def close(self):
        self.bw = None


class BaraffWitkinSolve:
    """The linear system of one Baraff-Witkin step, assembled by a kernel and solved by the
    Sim's formulation. `assemble()` and `solve()` are apart for the benchmark."""

    def __init__(self, sim):
        from ..kernel_types import ti
        self.sim, self.ti, self.nk = sim, ti, sim.nk
        size = 3 * sim.n_free
        self.a, self.kv = sim._scratch(2)
        self.blocks = ti.ndarray(sim.nk.mat3, sim.n_springs)
        self.rhs = np.zeros(size)
        self.iterations = 0
        if sim.variant == "cg":
            self.cg_scratch = [to_taichi(np.zeros(size)) for _ in range(3)]
            self.dv = np.zeros(size)
            self.nk.conjugate_gradient(sim.pack, self.blocks, self.rhs, self.dv,
                                       *self.cg_scratch, sim.dt, CG_RTOL, 0)  # compiles it
        else:
            triplets = 3 * sim.n_free + 36 * sim.n_springs
            self.builder = ti.linalg.SparseMatrixBuilder(size, size, max_num_triplets=triplets,
                                                         dtype=ti.f64)
            self.solver = ti.linalg.SparseSolver(dtype=ti.f64, solver_type="LDLT",
                                                 ordering="AMD")
            self.analysed = False
        self.assemble()  # compiles the assembly kernel on first use

    def assemble(self):
        """f, rhs and A (triplets built into a SparseMatrix, or the blocks for CG)."""
        s, nk = self.sim, self.nk
        if s.variant == "cg":
            nk.bw_blocks(s.pack, s.x, s.v, self.a, self.kv, self.blocks, self.rhs, s.dt)
            return None
        nk.bw_triplets(s.pack, s.x, s.v, self.a, self.kv, self.blocks, self.rhs,
                       self.builder, s.dt)
        return self.builder.build()

    def solve(self, matrix):
        """dv from the assembled system."""
        s = self.sim
        if s.variant == "cg":
            size = len(self.rhs)
            self.iterations = self.nk.conjugate_gradient(
                s.pack, self.blocks, self.rhs, self.dv, *self.cg_scratch, s.dt, CG_RTOL,
                CG_MAXITER_PER_DOF * size)
            if self.iterations < 0:
                raise EngineFailure(f"taichi baraff_witkin CG did not reach rtol {CG_RTOL:g} in "
                                    f"{CG_MAXITER_PER_DOF * size} iterations (a compressed "
                                    "spring makes the matrix indefinite)")
            return self.dv.copy()
        if not self.analysed:
            self.solver.analyze_pattern(matrix)
            self.analysed = True
        self.solver.factorize(matrix)
        if not self.solver.info():
            raise EngineFailure("taichi SparseSolver LDLT could not factorise M - h D - h^2 K")
        return np.asarray(self.solver.solve(self.rhs), dtype=np.float64)

    def velocity_change(self):
        return self.solve(self.assemble())


def _stepper_kernels(nk, bending):
    """(start, symplectic_euler, velocity_verlet, rk4): the stretch-only family, or the
    family for the bending terms present (hinges, dihedrals)."""
    if not any(bending):
        return nk.start, nk.symplectic_euler, nk.velocity_verlet, nk.rk4
    from ..bending_kernels import steppers
    return steppers(*bending)


def build(engine, scene, dt, integrator, formulation):
    return NetworkSim(scene, dt, integrator, formulation)


MODEL_GROUP = ModelGroup(name="spring_network", build=build, claims=claims,
                         parts=frozenset({"networks"}),
                         features=frozenset({"networks", "gravity", "drag"}),
                         supports=supports, formulations=formulations,
                         integrators=NETWORK_INTEGRATORS)
