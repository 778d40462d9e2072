"""A compiled MuJoCo flex of one P1 mesh (fem_mjcf): stepped dynamics (`MujocoFemSim`) and the
settle to a static equilibrium (`MujocoFemSettle`, the fem group's "steady").

Stepping (mj_step with nstep, the bad-state warning counters, warnings to a callback) and
`close` are MujocoSim's. Observed: x, v (n, 3) of every node: a free node's position is its
rest vertex plus the qpos of its slides (the world axes), which is what `d.flexvert_xpos`
holds once MuJoCo has run its position stage (mj_step leaves flexvert_xpos at the start of
the last step); pinned nodes at their positions with v = 0.
"""
from __future__ import annotations

import time

import numpy as np

from .fem_mjcf import FemLayout, check_model, fem_model, flex_constants, mesh_of, vertex_dofs
from .fem_settle import Settle, settle_plan
from .fem_yield import describe
from .point_masses import POINT_INERTIA
from .sim import BAD_WARNINGS, MujocoSim

_PARTICLE_KEYS = ("contacts", "inertia", "drag", "bodies", "eulerdamp")


class MujocoFemSim(MujocoSim):
    """The mesh's flex stepped by MuJoCo's integrator (`method`) at the scene's dt."""

    def __init__(self, scene, dt, integrator, method, treated_implicitly: str):
        import mujoco
        self.mj, self.scene, self.dt = mujoco, scene, float(dt)
        self.integrator, self.method = integrator, method
        self.treated_implicitly = treated_implicitly
        self.plans, self.spheres, self.contact, self.rods = [], False, None, 0
        self.steps, self.failure, self._messages = 0, None, []
        self.layout = FemLayout(mesh_of(scene))
        self.timestep, self.rayleigh, self.alpha = self._damping_and_step()
        t0 = time.perf_counter()
        self.model = fem_model(self.layout, scene.gravity, self.timestep, method.xml,
                               self.rayleigh, self.alpha)
        self.compile_s = time.perf_counter() - t0
        self._check_model()
        check_model(self.model, self.layout, self.rayleigh, self.alpha)
        self.data = mujoco.MjData(self.model)
        self._qadr, self._dadr = vertex_dofs(self.model, self.layout)
        self._loaded = self._load_bodies()
        self._bad = np.array([int(getattr(mujoco.mjtWarning, w)) for w in BAD_WARNINGS])
        self._counts = self.data.warning.number
        self._set_initial_state()

    def _damping_and_step(self):
        """(MuJoCo timestep, Rayleigh damping, mass damping alpha): the scene's dt, none."""
        return self.dt, 0.0, 0.0

    def _check_model(self):
        """The options asked for (MujocoSim's check, at this model's own timestep)."""
        dt, self.dt = self.dt, self.timestep
        try:
            super()._check_model()
        finally:
            self.dt = dt

    def _load_bodies(self):
        mesh, m = self.layout.mesh, self.model
        loaded = np.flatnonzero(np.any(mesh.loads != 0, axis=1) & self.layout.free)
        return m.flex_vertbodyid[m.flex_vertadr[0] + loaded], mesh.loads[loaded]

    def _set_initial_state(self):
        """Free vertices at the mesh's positions (qpos = position - rest vertex), velocities
        through qvel, the loads in xfrc_applied."""
        mesh, free, d = self.layout.mesh, self.layout.free, self.data
        self.mj.mj_resetData(self.model, d)
        d.qpos[self._qadr] = (mesh.positions - mesh.vertices)[free][:, :self.layout.dof]
        d.qvel[self._dadr] = mesh.velocities[free][:, :self.layout.dof]
        bodies, loads = self._loaded
        d.xfrc_applied[bodies, :3] = loads

    # -- observation --------------------------------------------------------------------------
    def positions(self) -> np.ndarray:
        mesh, free, dof = self.layout.mesh, self.layout.free, self.layout.dof
        x = np.array(mesh.positions, float)
        x[free, :dof] = mesh.vertices[free, :dof] + self.data.qpos[self._qadr]
        return x

    def _observe(self):
        free, dof = self.layout.free, self.layout.dof
        v = np.zeros((len(free), 3))
        v[free, :dof] = self.data.qvel[self._dadr]
        return {"x": self.positions(), "v": v}

    # -- settings -----------------------------------------------------------------------------
    def settings(self):
        out = self._base_settings()
        for key in _PARTICLE_KEYS:
            out.pop(key, None)
        out["timestep"] = self.timestep  # MuJoCo's own (the settle's, for "steady")
        out["integrator"]["implicit"] = not self.method.explicit
        out["integrator"]["treated_implicitly"] = self.treated_implicitly
        out.update(self._fem_settings())
        return out

    def _fem_settings(self) -> dict:
        layout, mesh = self.layout, self.layout.mesh
        mat = mesh.material
        young, poisson = flex_constants(mesh)
        out = {
            "model": {"law": "green (St Venant-Kirchhoff: MuJoCo flex's only law)",
                      "element": "P1 triangle" if layout.triangles else "P1 tetrahedron",
                      "youngs_modulus": mat.youngs_modulus, "poisson_ratio": mat.poisson_ratio,
                      "nodes": len(mesh), "elements": len(mesh.elements),
                      "free_nodes": int(layout.free.sum()), "pinned": len(mesh.pinned)},
            "formulation": "flexcomp type=direct dim=%s dof=%s, <pin id> for pinned nodes, "
                           "<elasticity young poisson%s damping>" % (
                               ("2", "2d (slides x, y)", " thickness elastic2d=stretch")
                               if layout.triangles else ("3", "full (slides x, y, z)", "")),
            "plane": self._plane(),
            "flex_young": young, "flex_poisson": poisson,
            "thickness": mesh.thickness if layout.triangles else None,
            "plasticity": describe(mesh),
            "rayleigh_damping": self.rayleigh, "edge_stiffness": 0.0, "edge_damping": 0.0,
            "mass": "refsim's lumped rho V / (d + 1) per free vertex body (set in the "
                    "MjSpec), instead of flexcomp's equal split",
            "mass_split": layout.mass_comparison(),
            "inertia": f"vertex bodies: diaginertia {POINT_INERTIA:g} (slides only: never "
                       "enters)",
            "loads": "constant, d.xfrc_applied[flex_vertbodyid[v], :3]",
            "pinned_positions": "written into the compiled flex_vert (world body): the rest "
                                "shape stays the mesh's vertices",
            "contacts": "disabled (flag contact=disable, flex contype 0)",
            "velocity_limits": "none (MuJoCo clamps no velocities)",
            "observation": "x = rest vertex + qpos of the vertex's slides (= flexvert_xpos "
                           "after MuJoCo's position stage), v = qvel; pinned nodes at their "
                           "positions with v = 0",
        }
        if self.integrator == "discrete":
            out["solver"] = "discrete's linear solve: MuJoCo's own (option solver Newton, " \
                            "tolerance and iterations of the network group)"
        return out


    def _plane(self) -> str:
        if not self.layout.triangles:
            return "3-D"
        text = ("stress (MuJoCo's 2-D flex: lambda* = E nu / (1 - nu^2), energy x "
                "thickness)")
        if self.layout.mesh.plane == "strain":
            text = ("strain, run as " + text + " with E' = E / (1 - nu^2), nu' = nu / "
                    "(1 - nu): the same in-plane StVK law (mu, and lambda* = the 3-D lambda)")
        return text


class MujocoFemSettle(MujocoFemSim):
    """"steady": one step is one complete settle from the initial state by MuJoCo's Euler with
    mass-proportional damping (fem_settle), stopped by its rule; observes `residual` (max
    |elastic + external force| on the free dofs at the end, MuJoCo's own forces, N) and
    `iterations` (MuJoCo steps of the last settle)."""

    def _damping_and_step(self):
        self.plan = settle_plan(self.layout)
        return self.plan.timestep, 0.0, self.plan.alpha

    def _set_initial_state(self):
        super()._set_initial_state()
        self.data.qvel[:] = 0.0  # a static scene's equilibrium is sought from rest
        self.residual, self.iterations, self.stopped = float("nan"), 0, ""
        self._x = self.positions()

    def _step_impl(self, n):
        for _ in range(n):  # every step the same complete settle from the initial state
            self._set_initial_state()
            settle = Settle(self, self.plan)
            settle.run()
            if self.failure:
                return
            self.residual, self.iterations, self.stopped = settle.result()
            self._x = self.positions()

    def _observe(self):
        return {"x": self._x.copy(), "v": np.zeros_like(self._x),
                "residual": self.residual, "iterations": self.iterations}

    def settings(self):
        out = super().settings()
        out["integrator"].update(order=0, symplectic=False, family="damped dynamics to "
                                 "equilibrium (MuJoCo Euler, mass-proportional damping)")
        out["step"] = ("one complete settle from the initial positions (rest velocities), "
                       "MuJoCo's own timestep below")
        out["settle"] = self.plan.describe()
        out["last_stop"] = self.stopped
        return out
