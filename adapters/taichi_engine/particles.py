"""Point masses (gravity, linear drag, springs to fixed anchors) and hinged rods (one rod per
body, in generalized coordinates) stepped by the kernels of particle_kernels."""
from __future__ import annotations

import numpy as np

from ..common.hinges import HingeFrames
from .kernel_store import observed, to_ndarray, to_taichi
from .sim import KernelSim


def particle_pack(scene):
    """The `particles_t` argpack of a scene: 1/m, gravity, drag and the springs to anchors
    (a dummy spring on body -1 when there are none)."""
    from .kernel_types import vec3
    from .particle_kernels import particles_t
    springs = scene.springs
    arrays = {"inv_m": 1.0 / scene.masses,
              "spring_body": np.array([s.body for s in springs] or [-1], np.int32),
              "spring_anchor": np.array([s.anchor for s in springs] or [(0.0,) * 3], float),
              "spring_k": np.array([s.stiffness for s in springs] or [0.0], float),
              "spring_rest": np.array([s.rest_length for s in springs] or [0.0], float),
              "spring_c": np.array([s.damping for s in springs] or [0.0], float)}
    velocity_dependent = int(scene.linear_drag > 0 or any(s.damping > 0 for s in springs))
    return particles_t(gravity=vec3(*scene.gravity), drag=scene.linear_drag,
                       velocity_dependent=velocity_dependent,
                       **{key: to_taichi(arr) for key, arr in arrays.items()})


def force_stages(scene) -> list:
    """The force terms a particle scene switches on, in settings' order."""
    return [name for name, on in (("gravity", any(scene.gravity)),
                                  ("drag", scene.linear_drag > 0),
                                  ("springs", bool(scene.springs))) if on]


class ParticleSim(KernelSim):
    system = "particles"

    def __init__(self, scene, dt, integrator, variant):
        self.scene = scene
        n = len(scene.bodies)
        self.x, self.v = to_ndarray(scene.positions), to_ndarray(scene.velocities)
        accel = to_taichi(np.zeros((n, 3)))
        super().__init__(dt, integrator, variant, (self.x, self.v, accel, particle_pack(scene)))

    def _observe(self):
        return {"x": observed(self.x), "v": observed(self.v)}

    def settings(self):
        return {**self.base_settings(), "formulation": "cartesian point masses",
                "stages": force_stages(self.scene) + [f"integrate:{self.integrator}"],
                "springs": "to fixed anchors, -k (|d| - L0) u - c (v.u) u",
                "drag": "linear, f = -b v, applied exactly in the force"}


class HingeSim(KernelSim):
    """Rods in generalized coordinates: theta'' = -(g/L) sin theta - (b/m) theta', the angle
    mapped to the bob with refsim's hinge frame (adapters.common.hinges.HingeFrames)."""

    system = "hinges"
    host_arrays = ("theta", "omega")

    def __init__(self, scene, dt, integrator, variant):
        from .particle_kernels import hinges_t
        self.scene = scene
        self.frames = frames = HingeFrames.from_scene(scene)
        theta0, omega0 = frames.initial_angles(scene.positions, scene.velocities)
        masses = scene.masses[frames.bodies]
        arrays = [np.asarray(theta0, float), np.asarray(omega0, float),
                  np.zeros(len(frames.bodies)), frames.g_plane / frames.length,
                  np.full(len(frames.bodies), scene.linear_drag) / masses]
        nd = [to_ndarray(np.asarray(arr, float)) for arr in arrays[:2]]  # theta, omega
        nd += [to_taichi(np.asarray(arr, float)) for arr in arrays[2:]]
        pack = hinges_t(g_over_l=nd[3], drag_over_m=nd[4],
                        velocity_dependent=int(scene.linear_drag > 0))
        self.x, self.v = nd[0], nd[1]
        super().__init__(dt, integrator, variant, (*nd[:3], pack))

    def _observe(self):
        x, v = self.frames.cartesian(observed(self.x), observed(self.v),
                                     self.scene.positions, self.scene.velocities)
        return {"x": x, "v": v, "constraint": np.zeros(len(self.frames.bodies))}

    def settings(self):
        stages = ["gravity"] if any(self.scene.gravity) else []
        if self.scene.linear_drag > 0:
            stages.append("drag")
        return {**self.base_settings(), "formulation": "generalized coordinate (hinge angle)",
                "stages": stages + ["hinge_generalized", f"integrate:{self.integrator}"],
                "hinge_frame": {"d": self.frames.d.tolist(), "s": self.frames.s.tolist()},
                "constraint": "exact by construction (rod length errors reported as 0)"}
