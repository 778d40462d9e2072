"""taichi's rigid-body model group: free rigid bodies (Newton-Euler, world frame) under gravity,
stepped by the float64 kernels of `refsim_adapters.taichi_engine.rigid_kernels` (the model of
issue 13 that refsim's numpy rigid model follows, and refsim's steppers: the two agree to round-off at
equal formulation and stepper).

Claims scenes whose only part is `rigid` (RigidBodies; gravity allowed, nothing else).
Formulations: "quat_exp" (exponential-map update) and "quat_normalised"
(Euler quaternion update, then normalisation). Integrators: symplectic_euler, rk4 (RKMK4:
classical RK4 with the stage slopes corrected by dexp^-1, or dcay^-1 under quat_normalised,
order 4 on the rotation group, see rigid_kernels).

Observables: x, v, q, w (refsim.observation, world frame), and the extras
- "orientation_defect" (n,): |q|^2 - 1 under quat_exp; under quat_normalised the product of the
  squared norms removed by every normalisation so far, minus 1 (the drift it hid);
- "energy" (n,) J per body: 1/2 m |v|^2 + 1/2 w . L - m g . x;
- "angular_momentum" (n, 3) kg m^2/s: world angular momentum I_w w about each COM.
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup
from refsim.scene import RigidBodies

from ..kernel_store import observed, to_ndarray, to_taichi
from ..runtime import runtime
from ..sim import KernelSim

INTEGRATORS = ("symplectic_euler", "rk4")
FORMULATIONS = ("quat_exp", "quat_normalised")
GROUP_ORDER = {"symplectic_euler": 1, "rk4": 4}  # on the rotation group (rk4: RKMK4)
# the rotational kick w += h w'(q_k, w_k) is explicit Euler on the gyroscopic term: not a
# symplectic (Lie-Poisson) map, and the top's energy grows secularly (measured: +8.6e-2 of the
# rotational energy over t = 100 at h = 1e-2, tests/engines/taichi/test_taichi_rigid.py)
NOT_SYMPLECTIC = ("kick-drift on (x, v) only: the rotational update is explicit in the "
                  "gyroscopic term w x I_w w, so energy drifts secularly")
ORIENTATION = {"quat_exp": "q <- exp(h w / 2) (x) q (exponential map, world w on the left)",
               "quat_normalised": "q <- normalise(q + h/2 (0, w) (x) q); the squared norms "
                                  "removed are multiplied into orientation_defect + 1"}
ORIENTATION_DEFECT = {"quat_exp": "|q|^2 - 1",
                      "quat_normalised": "product of the squared norms removed by the "
                                         "normalisations so far, minus 1"}
NATIVE = {"symplectic_euler": "kernel symplectic_euler: w += h w'(q, w); v += h g; x += h v; "
                              "q moved by h w (new w)",
          "rk4": "kernel rk4: classical RK4 as Runge-Kutta-Munthe-Kaas (RKMK4): stage "
                 "orientations q (+) h sum a_ij K_j from the base point, stage slopes "
                 "K_i = dexp^-1 W_i (quat_exp) or dcay^-1 W_i (quat_normalised, Cayley map) "
                 "at the stage increment, as refsim's explicit RK with its dexpinv hook"}
STAGE_CORRECTION = {"quat_exp": "dexp^-1 of the exponential map (RKMK)",
                    "quat_normalised": "dcay^-1 of the Cayley map (RKMK)"}


def claims(scene) -> bool:
    """A scene whose parts are rigid bodies only."""
    return scene.part_kinds() == {"rigid"}


def supports(engine, scene, integrator):
    if integrator is not None and integrator not in INTEGRATORS:
        return (f"taichi rigid group: integrator must be one of {list(INTEGRATORS)} "
                f"(got {integrator!r})")
    return None


def formulations(engine, scene):
    return FORMULATIONS


def build(engine, scene, dt, integrator, formulation):
    if integrator not in INTEGRATORS:
        raise ValueError(f"taichi rigid integrator must be one of {list(INTEGRATORS)}, got "
                         f"{integrator!r}")
    return RigidSim(scene, dt, integrator, formulation)  # the base checked it in FORMULATIONS


def rotation_matrices(q: np.ndarray) -> np.ndarray:
    """(n, 3, 3) R(q) of (n, 4) quaternions (w, x, y, z) taken as unit (body to world)."""
    w, x, y, z = np.moveaxis(np.asarray(q, float), -1, 0)
    rows = ((1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
            (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
            (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)))
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


def world_momentum(inertia0, q, w) -> np.ndarray:
    """L = R I0 R^T w per body (n, 3)."""
    R = rotation_matrices(q)
    w_body = np.einsum("nji,nj->ni", R, w)
    return np.einsum("nij,nj->ni", R, np.einsum("nij,nj->ni", inertia0, w_body))


class RigidSim(KernelSim):
    """Rigid bodies stepped by rigid_kernels; kernels made once per process and stepper."""

    system = "rigid"
    host_arrays = ("x", "v", "q", "w", "norm_product")

    def __init__(self, scene, dt, integrator, formulation):
        from .. import rigid_kernels as rk
        body = self.body = scene.part(RigidBodies)
        self.scene, self.formulation = scene, formulation
        made = runtime()["kernels"]
        if (self.system, integrator) not in made:  # runtime's cache, keyed as its own kernels
            made[(self.system, integrator)] = rk.rigid_kernels(integrator)
        n = len(body)
        self.x, self.v, self.w = (to_ndarray(a) for a in
                                  (body.position, body.velocity, body.angular_velocity))
        self.q = to_ndarray(body.orientation)  # (n, 4): vec4 rows
        self.norm_product = to_ndarray(np.ones(n))
        pack = rk.rigid_t(inertia0=to_taichi(body.inertia, rk.mat3),
                          inertia0_inv=to_taichi(np.linalg.inv(body.inertia), rk.mat3),
                          gravity=rk.vec3(*scene.gravity),
                          normalise=rk.FORMULATIONS.index(formulation))
        super().__init__(dt, integrator, "", (self.x, self.v, self.q, self.w,
                                              self.norm_product, pack))

    def _observe(self):
        x, v, q, w = (observed(a) for a in (self.x, self.v, self.q, self.w))
        body = self.body
        L = world_momentum(body.inertia, q, w)
        if self.formulation == "quat_exp":
            defect = np.einsum("ni,ni->n", q, q) - 1.0
        else:
            defect = self.norm_product - 1.0
        energy = (0.5 * body.mass * np.einsum("ni,ni->n", v, v)
                  + 0.5 * np.einsum("ni,ni->n", w, L) - body.mass * (x @ np.asarray(
                      self.scene.gravity, float)))
        return {"x": x, "v": v, "q": q, "w": w, "orientation_defect": defect,
                "energy": energy, "angular_momentum": L}

    def settings(self):
        base = self.base_settings()
        info = {**base["integrator"], "native": NATIVE[self.integrator],
                "order": GROUP_ORDER[self.integrator], "symplectic": False,
                "nominal_order": base["integrator"]["order"],
                "why_not_symplectic": NOT_SYMPLECTIC if self.integrator == "symplectic_euler"
                else "explicit Runge-Kutta"}
        return {**base, "integrator": info, "formulation": self.formulation,
                "orientation_update": ORIENTATION[self.formulation],
                "rk_stage_correction": STAGE_CORRECTION[self.formulation],
                "time_loop": "one launch per step(n): bodies outermost (parallel over "
                             f"{base['threads']} thread(s)), each body's n steps serial inside",
                "model": "m v' = m g; I_w w' + w x (I_w w) = 0 with I_w = R I0 R^T, "
                         "evaluated as w' = -R I0^-1 (w_b x I0 w_b), w_b = R^T w",
                "torque": "none (gravity acts at the COM)", "damping": "none",
                "velocity_clamp": "none",
                "orientation_defect": ORIENTATION_DEFECT[self.formulation],
                "energy": "per body: 1/2 m |v|^2 + 1/2 w . I_w w - m g . x"}


MODEL_GROUP = ModelGroup(name="rigid", build=build, claims=claims, parts=frozenset({"rigid"}),
                         features=frozenset({"rigid", "gravity"}), supports=supports,
                         formulations=formulations, integrators=INTEGRATORS)
