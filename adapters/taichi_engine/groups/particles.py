"""taichi's particles group: point masses under gravity and linear drag with springs to fixed
anchors (`ParticleSim`, Cartesian), or hanging from hinged rods, one rod per body
(`HingeSim`, in generalized coordinates), stepped by the kernels of particle_kernels (three
steppers, one signature).

Claims scenes of particles with springs and joints (either optional), no contact model.
Formulations: "" (the time loop inside one kernel) and "launch_per_step" (one launch per step
from Python: its measured cost is reported). Integrators: symplectic_euler, velocity_verlet,
rk4. Refused, with the reason: springs between two bodies; a body with no rod or two rods
beside hinged ones; springs on a rod's body.
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup
from refsim.scene import Joints, Particles, Springs

from ...common.checks import body_to_body_springs, rods_per_body, springs_on_rod_bodies
from ...common.hinges import HingeFrames
from ..engine import WHO
from ..forces import force_stages, particle_pack
from ..kernel_store import observed, to_ndarray, to_taichi
from ..sim import INTEGRATORS, KernelSim, checked_integrator

PARTS = frozenset({"particles", "springs", "joints"})
FEATURES = frozenset({"gravity", "springs", "joints", "drag"})
FORMULATIONS = ("", "launch_per_step")


def claims(scene) -> bool:
    """Particles with springs and joints at most, no contact model."""
    return scene.part(Particles) is not None and scene.part_kinds() <= PARTS \
        and scene.contact is None


def supports(engine, scene, integrator):
    reason = body_to_body_springs(scene, WHO, " (only springs to fixed anchors)")
    if reason:
        return reason
    if scene.part(Joints) is not None:
        return hinge_refusal(scene)
    return None


def hinge_refusal(scene):
    """Why a scene with joints cannot be run in generalized coordinates here, or None."""
    return (rods_per_body(scene, WHO, every_body=True, why=" (generalized coordinates)")
            or springs_on_rod_bodies(scene, WHO))


def formulations(engine, scene):
    return FORMULATIONS


def build(engine, scene, dt, integrator, formulation):
    checked_integrator(integrator)
    particles = scene.part(Particles)
    if scene.part(Joints) is not None:
        return HingeSim(particles, HingeFrames.from_scene(scene), scene.gravity,
                        scene.linear_drag, dt, integrator, formulation)
    return ParticleSim(particles, scene.part(Springs), scene.gravity, scene.linear_drag, dt,
                       integrator, formulation)


class ParticleSim(KernelSim):
    """Point masses in Cartesian coordinates: gravity, linear drag, springs to anchors."""

    system = "particles"

    def __init__(self, particles, springs, gravity, drag, dt, integrator, formulation):
        self.gravity, self.drag, self.has_springs = gravity, drag, springs is not None
        self.x, self.v = to_ndarray(particles.position), to_ndarray(particles.velocity)
        accel = to_taichi(np.zeros((len(particles), 3)))
        pack = particle_pack(particles.mass, springs, gravity, drag)
        super().__init__(dt, integrator, formulation, (self.x, self.v, accel, pack))

    def _observe(self):
        return {"x": observed(self.x), "v": observed(self.v)}

    def settings(self):
        stages = force_stages(self.gravity, self.drag, self.has_springs)
        return {**self.base_settings(), "formulation": "cartesian point masses",
                "stages": stages + [f"integrate:{self.integrator}"],
                "springs": "to fixed anchors, -k (|d| - L0) u - c (v.u) u",
                "drag": "linear, f = -b v, applied exactly in the force"}


class HingeSim(KernelSim):
    """Rods in generalized coordinates: theta'' = -(g/L) sin theta - (b/m) theta', the angle
    mapped to the bob with refsim's hinge frame (adapters.common.hinges.HingeFrames)."""

    system = "hinges"
    host_arrays = ("theta", "omega")

    def __init__(self, particles, frames, gravity, drag, dt, integrator, formulation):
        from ..particle_kernels import hinges_t
        self.particles, self.frames, self.gravity, self.drag = particles, frames, gravity, drag
        theta0, omega0 = frames.initial_angles(particles.position, particles.velocity)
        masses = particles.mass[frames.bodies]
        arrays = [np.asarray(theta0, float), np.asarray(omega0, float),
                  np.zeros(len(frames.bodies)), frames.g_plane / frames.length,
                  np.full(len(frames.bodies), drag) / masses]
        nd = [to_ndarray(np.asarray(arr, float)) for arr in arrays[:2]]  # theta, omega
        nd += [to_taichi(np.asarray(arr, float)) for arr in arrays[2:]]
        pack = hinges_t(g_over_l=nd[3], drag_over_m=nd[4], velocity_dependent=int(drag > 0))
        self.x, self.v = nd[0], nd[1]
        super().__init__(dt, integrator, formulation, (*nd[:3], pack))

    def _observe(self):
        x, v = self.frames.cartesian(observed(self.x), observed(self.v),
                                     self.particles.position, self.particles.velocity)
        return {"x": x, "v": v, "constraint": np.zeros(len(self.frames.bodies))}

    def settings(self):
        stages = ["gravity"] if any(self.gravity) else []
        if self.drag > 0:
            stages.append("drag")
        return {**self.base_settings(), "formulation": "generalized coordinate (hinge angle)",
                "stages": stages + ["hinge_generalized", f"integrate:{self.integrator}"],
                "hinge_frame": {"d": self.frames.d.tolist(), "s": self.frames.s.tolist()},
                "constraint": "exact by construction (rod length errors reported as 0)"}


MODEL_GROUP = ModelGroup(name="particles", build=build, claims=claims, parts=PARTS,
                         features=FEATURES, supports=supports, formulations=formulations,
                         integrators=INTEGRATORS)
