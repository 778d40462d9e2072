"""taichi's pivoted rigid bodies: every rigid body of the scene turns about a fixed point
(`RigidPivots`, a ball joint to the world), stepped by the float64 kernels of
`refsim_adapters.taichi_engine.pivot_kernels`, the model of `refsim.models.rigid_pivot` (the
two agree to round-off at equal formulation and stepper). The state is (q, w) per body: the pivot holds
the centre of mass on its sphere exactly (x = anchor + R c), no constraint force.

Claims scenes of rigid bodies and a RigidPivots part, every body pivoted once. Formulations:
"quat_exp" and "quat_normalised" (rigid_kernels.rotate_by). Integrators:
symplectic_euler, rk4 (RKMK4, rigid_kernels.rkmk4: the dexp^-1 / dcay^-1 stage correction,
order 4 on the rotation group).

Observables, as refsim's pivots group: x (anchor + R c), v (w x R c), q, w (world), and the
extras "orientation_defect" (n,) (|q|^2 - 1 under quat_exp; the product of the squared norms
removed by normalising, minus 1, under quat_normalised), "energy" () J (sum over bodies of
1/2 w . L - m g . x), "angular_momentum" (n, 3) world L = I_p w ABOUT EACH PIVOT, "pivot_gap"
(n,) |x - R c - anchor| (round-off: the joint is exact).
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup
from refsim.models.rigid_pivot import pivot_inertia
from refsim.scene import RigidBodies
from refsim.scene.pivots import RigidPivots, check_on_anchor

from ..kernel_store import observed, to_ndarray, to_taichi
from ..sim import KernelSim
from .rigid import (
    FORMULATIONS,
    GROUP_ORDER,
    INTEGRATORS,
    ORIENTATION,
    ORIENTATION_DEFECT,
    STAGE_CORRECTION,
    rotation_matrices,
)

NATIVE = {"symplectic_euler": "kernel symplectic_euler: w += h w'(q, w); q moved by h w (new w)",
          "rk4": "kernel rk4: classical RK4 on (q, w) as Runge-Kutta-Munthe-Kaas (RKMK4): "
                 "stage orientations q (+) h sum a_ij K_j from the base point, stage slopes "
                 "K_i = dexp^-1 W_i (quat_exp) or dcay^-1 W_i (quat_normalised, Cayley map) "
                 "at the stage increment, as refsim's explicit RK with its dexpinv hook"}
NOT_SYMPLECTIC = ("w is stepped with the explicit gyroscopic term w x (I_p w) (not a momentum or "
                  "Lie-Poisson step): a tumbling top's energy drifts secularly")


def claims(scene) -> bool:
    """Rigid bodies and a RigidPivots part, nothing else."""
    return scene.part_kinds() == {"rigid", "rigid_pivots"} and scene.contact is None


def supports(engine, scene, integrator):
    if integrator is not None and integrator not in INTEGRATORS:
        return (f"taichi pivots group: integrator must be one of {list(INTEGRATORS)} "
                f"(got {integrator!r})")
    if scene.dim != 3:
        return "taichi pivoted bodies are 3D (quaternion orientation)"
    pivots, n = scene.part(RigidPivots), len(scene.part(RigidBodies))
    if len(pivots) != n or sorted(pivots.body.tolist()) != list(range(n)):
        return (f"taichi pivots need every rigid body pivoted once ({n} bodies, pivots on "
                f"{sorted(pivots.body.tolist())})")
    return None


def formulations(engine, scene):
    return FORMULATIONS


def build(engine, scene, dt, integrator, formulation):
    if integrator not in INTEGRATORS:
        raise ValueError(f"taichi pivot integrator must be one of {list(INTEGRATORS)}, got "
                         f"{integrator!r}")
    return PivotSim(scene, dt, integrator, formulation)


class PivotSim(KernelSim):
    """Pivoted bodies stepped by pivot_kernels; kernels made once per process and stepper."""

    system = "pivots"
    host_arrays = ("q", "w", "norm_product")

    def __init__(self, scene, dt, integrator, formulation):
        from .. import pivot_kernels as pk
        from .. import rigid_kernels as rk
        body, pivots = scene.part(RigidBodies), scene.part(RigidPivots)
        check_on_anchor(pivots, body)
        order = np.argsort(pivots.body)  # every body pivoted once: sorted bodies = 0..n-1
        self.scene, self.body, self.formulation = scene, body, formulation
        self.com_offset = -pivots.body_point[order]
        self.anchor = pivots.anchor[order]
        self.inertia_pivot = pivot_inertia(body.inertia, body.mass, self.com_offset)
        self.weight = body.mass[:, None] * np.asarray(scene.gravity, float)
        made = runtime_kernels()
        if (self.system, integrator) not in made:
            made[(self.system, integrator)] = pk.pivot_kernels(integrator)
        self.q = to_ndarray(body.orientation)
        self.w = to_ndarray(body.angular_velocity)
        self.norm_product = to_ndarray(np.ones(len(body)))
        pack = pk.pivot_t(inertia_pivot=to_taichi(self.inertia_pivot, rk.mat3),
                          inertia_pivot_inv=to_taichi(np.linalg.inv(self.inertia_pivot),
                                                      rk.mat3),
                          com_offset=to_taichi(self.com_offset),
                          weight=to_taichi(self.weight),
                          normalise=pk.FORMULATIONS.index(formulation))
        super().__init__(dt, integrator, "", (self.q, self.w, self.norm_product, pack))

    def _observe(self):
        q, w = observed(self.q), observed(self.w)
        rotation = rotation_matrices(q)
        arm = np.einsum("nij,nj->ni", rotation, self.com_offset)
        x = self.anchor + arm
        w_body = np.einsum("nji,nj->ni", rotation, w)
        momentum = np.einsum("nij,nj->ni", rotation,
                             np.einsum("nij,nj->ni", self.inertia_pivot, w_body))
        if self.formulation == "quat_exp":
            defect = np.einsum("ni,ni->n", q, q) - 1.0
        else:
            defect = self.norm_product - 1.0
        energy = 0.5 * np.einsum("ni,ni->", w, momentum) - np.sum(self.weight * x)
        return {"x": x, "v": np.cross(w, arm), "q": q, "w": w, "orientation_defect": defect,
                "energy": float(energy), "angular_momentum": momentum,
                "pivot_gap": np.linalg.norm(x - arm - self.anchor, axis=1)}

    def settings(self):
        base = self.base_settings()
        info = {**base["integrator"], "native": NATIVE[self.integrator],
                "order": GROUP_ORDER[self.integrator], "symplectic": False,
                "nominal_order": base["integrator"]["order"], "why_not_symplectic":
                NOT_SYMPLECTIC if self.integrator == "symplectic_euler"
                else "explicit Runge-Kutta"}
        return {**base, "integrator": info, "formulation": self.formulation,
                "orientation_update": ORIENTATION[self.formulation],
                "rk_stage_correction": STAGE_CORRECTION[self.formulation],
                "model": "I_p w' + w x (I_p w) = (R c) x m g, I_p = R I_pivot R^T, evaluated "
                         "as w' = R I_pivot^-1 (-(w_b x I_pivot w_b) + R^T tau), w_b = R^T w",
                "pivot": "ball joint in generalized coordinates (orientation only): the "
                         "centre of mass stays on its sphere exactly, no constraint force",
                "gyroscopic_term": "explicit: w x (I_p w) about the pivot, at the stepper's "
                                   "stages",
                "damping": "none", "velocity_clamp": "none",
                "orientation_defect": ORIENTATION_DEFECT[self.formulation],
                "energy": "sum over bodies of 1/2 w . I_p w - m g . x",
                "angular_momentum": "world I_p w about each pivot"}


def runtime_kernels() -> dict:
    """The runtime's kernel cache (one (start, advance) per system and stepper)."""
    from ..runtime import runtime
    return runtime()["kernels"]


MODEL_GROUP = ModelGroup(name="pivots", build=build, claims=claims,
                         parts=frozenset({"rigid", "rigid_pivots"}),
                         features=frozenset({"rigid", "gravity", "pivots"}), supports=supports,
                         formulations=formulations, integrators=INTEGRATORS)
