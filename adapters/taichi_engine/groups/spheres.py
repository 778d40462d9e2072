"""taichi's spheres group: colliding spheres under a contact model (features "contacts",
"walls"; symplectic_euler only), one kernel per `step(n)` (contact_kernels.advance_spheres), its
time loop serialised. Per step, in this order: kick-drift (v += h a(x, v); x += h v, refsim's
`symplectic_euler`: gravity, drag, springs to anchors); contacts on the drifted positions: broad
phase on a uniform grid, contact normals (contact_detection), Gauss-Seidel impulse passes,
positional projection (contact_kernels). A full contact list or non-finite positions become
`Sim.failure`.

Claims scenes of particles (springs, joints and walls optional) with a contact model or walls.
Formulations: "" and "launch_per_step" (as the particles group's) and "overlap_normal" (the
contact normal along the centre line at detection instead of at the time of impact).
Refused, with the reason: springs between two bodies; walls without a contact model; hinged
bodies; any stepper but symplectic_euler; a body of radius 0; with friction, a sphere of moment
of inertia 0.
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup
from refsim.scene import Joints, Particles, Springs, Walls

from ...common.checks import (body_to_body_springs, non_sphere_bodies,
                              spheres_without_inertia, walls_without_contact)
from ..engine import WHO
from ..forces import force_stages, particle_pack
from ..kernel_store import observed, to_ndarray, to_taichi
from ..sim import INTEGRATORS, KernelSim, checked_integrator
from .particles import FORMULATIONS as PARTICLE_FORMULATIONS

PARTS = frozenset({"particles", "springs", "joints", "walls"})
FEATURES = frozenset({"gravity", "springs", "joints", "drag", "contacts", "walls"})
FORMULATIONS = PARTICLE_FORMULATIONS + ("overlap_normal",)

MAX_PASSES = 100  # Gauss-Seidel impulse passes per step, at most
APPROACH_TOL = 1e-12  # approaching: u.n < -APPROACH_TOL (|u_a| + |u_b|)
CONTACT_SLOP = 1e-9  # in contact: gap <= CONTACT_SLOP (r_a + r_b) (catches round-off touching)
CELLS_PER_SPHERE = 8  # grid array size 8 N + 64 (the cell size grows past 2 r_max to fit)
CONTACTS_PER_SPHERE = 16  # contact list size 16 N + 64; more is reported as a failure
# the kernel's counters (contact_kernels.record), in the order of the `stats` array
STATS = ("dropped_contacts", "steps_without_grid", "max_passes", "steps_at_pass_cap",
         "impulses", "contacts", "steps")
HOST_CONTACT_ARRAYS = ("wall_impulse", "stats", "depth_max")  # read by Python: numpy


def claims(scene) -> bool:
    """Particles (springs, joints, walls at most) with a contact model or walls."""
    return scene.part(Particles) is not None and scene.part_kinds() <= PARTS \
        and (scene.contact is not None or scene.part(Walls) is not None)


def supports(engine, scene, integrator):
    return (body_to_body_springs(scene, WHO, " (only springs to fixed anchors)")
            or contact_refusal(scene, integrator))


def contact_refusal(scene, integrator):
    """Why a contact scene cannot be simulated faithfully here, or None."""
    if scene.contact is None:
        return walls_without_contact(scene, WHO, " for their restitution")
    if scene.part(Joints) is not None:
        return "taichi adapter: contacts with hinged bodies are not modelled"
    if integrator is not None and integrator != "symplectic_euler":
        return ("taichi adapter: contact scenes step with symplectic_euler only (kick-drift, "
                "then impulses; a multi-stage stepper would need the impact located in time)")
    return (non_sphere_bodies(scene, WHO)
            or spheres_without_inertia(scene, WHO, friction_only=True))


def formulations(engine, scene):
    return FORMULATIONS


def build(engine, scene, dt, integrator, formulation):
    checked_integrator(integrator)
    return SphereSim(scene.part(Particles), scene.part(Springs), scene.part(Walls),
                     scene.contact, scene.gravity, scene.linear_drag, dt, integrator,
                     formulation)


class SphereSim(KernelSim):
    """Spheres with contacts (and walls): kick-drift, then impulses on the drifted positions."""

    system = "spheres"
    host_arrays = ("x", "v", "w") + HOST_CONTACT_ARRAYS

    def __init__(self, particles, springs, walls, contact, gravity, drag, dt, integrator,
                 formulation):
        from ..contact_kernels import contacts_t
        self.contact, self.gravity, self.drag = contact, gravity, drag
        self.has_springs = springs is not None
        self.x, self.v, self.w = (to_ndarray(a) for a in (
            particles.position, particles.velocity, particles.angular_velocity))
        self.nd = self._contact_arrays(particles, walls)
        scalars = {"n_walls": 0 if walls is None else len(walls),
                   "restitution": contact.restitution, "friction": contact.friction,
                   "slop": CONTACT_SLOP, "approach_tol": APPROACH_TOL,
                   "cell_min": self.cell_min(particles.radius), "max_passes": MAX_PASSES,
                   "toi_normal": int(formulation != "overlap_normal")}
        contacts = contacts_t(**self.nd, **scalars)
        pack = particle_pack(particles.mass, springs, gravity, drag)
        super().__init__(dt, integrator, formulation, (self.x, self.v, self.w, pack, contacts))

    @staticmethod
    def cell_min(radius) -> float:
        """Smallest grid cell: the largest contact reach, 2 r_max (1 + slop), rounded up."""
        return 2.0 * float(radius.max()) * (1.0 + 2.0 * CONTACT_SLOP)

    @staticmethod
    def _contact_arrays(particles, walls) -> dict:
        """Per-sphere data (radius, 1/I from the scene: never recomputed), walls (one dummy
        when none), grid and contact-list scratch, wall impulse and counters."""
        n, inertia = len(particles), particles.inertia
        cells, cap = CELLS_PER_SPHERE * n + 64, CONTACTS_PER_SPHERE * n + 64
        arrays = {"radius": particles.radius,
                  "inv_inertia": np.divide(1.0, inertia, out=np.zeros(n), where=inertia > 0),
                  "wall_point": np.zeros((1, 3)) if walls is None else walls.point,
                  "wall_normal": np.array([(0.0, 0.0, 1.0)]) if walls is None else walls.normal,
                  "cell_count": np.zeros(cells, np.int32), "cell_start": np.zeros(cells, np.int32),
                  "cell_of": np.zeros(n, np.int32), "order": np.zeros(n, np.int32),
                  "sorted_x": np.zeros((n, 3)),
                  "contact_a": np.zeros(cap, np.int32), "contact_b": np.zeros(cap, np.int32),
                  "contact_n": np.zeros((cap, 3)), "wall_impulse": np.zeros((1, 3)),
                  "stats": np.zeros(len(STATS), np.int64), "depth_max": np.zeros(1)}
        return {key: (to_ndarray if key in HOST_CONTACT_ARRAYS else to_taichi)(arr)
                for key, arr in arrays.items()}

    def _step_impl(self, n):
        super()._step_impl(n)
        stats = self.contact_stats()
        if stats["dropped_contacts"]:
            self.failure = (f"contact list full: {stats['dropped_contacts']} contacts dropped "
                            f"(capacity {self.nd['contact_a'].shape[0]}) by "
                            f"t={self.time_after(n):.6g}")
        elif stats["steps_without_grid"]:
            self.failure = f"non-finite positions: contacts skipped by t={self.time_after(n):.6g}"

    def contact_stats(self) -> dict:
        """Counters since build (see STATS) and the deepest overlap met before projection."""
        out = dict(zip(STATS, (int(c) for c in self.nd["stats"])))
        out["depth_max"] = float(self.nd["depth_max"][0])
        return out

    def _observe(self):
        return {"x": observed(self.x), "v": observed(self.v), "w": observed(self.w),
                "wall_impulse": observed(self.nd["wall_impulse"]).reshape(3)}

    def settings(self):
        contact = self.contact
        normal = ("centre line at detection (the penetrating configuration), as most engines"
                  if self.variant == "overlap_normal" else
                  "at the time of impact on the straight relative path of the last drift "
                  "(|d - s v_rel| = r_a + r_b, |s| <= dt), else the centre line")
        stages = force_stages(self.gravity, self.drag, self.has_springs)
        integ = {**self.base_settings()["integrator"],
                 "note": "kick-drift between impacts; impulses after the drift"}
        return {**self.base_settings(), "integrator": integ,
                "formulation": "spheres with impulse contacts",
                "stages": stages + ["integrate:symplectic_euler", "broad_phase:grid",
                                    "contact_normals", "impulses:gauss_seidel",
                                    "projection"],
                "step_order": "kick v += h a(x, v); drift x += h v; detect on the drifted "
                              "positions; impulse passes; positional projection",
                "contact_model": "impulse",
                "restitution": contact.restitution,
                "restitution_mapping": "e used as is in Newton's law along n: J_n = -(1 + e) "
                                       "(u.n) / (1/m_a + 1/m_b) (no per-body product)",
                "friction": contact.friction,
                "friction_model": "Coulomb, Guendelman et al. 2003: stick (J_t = -u_t / k_t, "
                                  "k_t = 1/m_a + 1/m_b + r_a^2/I_a + r_b^2/I_b) when |J_t| <= "
                                  "mu J_n, else slide with mu J_n against u_t",
                "inertia": "from the scene (2/5 m r^2 for the case's solid spheres), never "
                           "recomputed",
                "solver": {"kind": "sequential (Gauss-Seidel) pair impulses over the contact "
                                   "list in a fixed order", "max_passes": MAX_PASSES,
                           "stop": "a pass with no approaching contact",
                           "approaching": f"u.n < -{APPROACH_TOL:g} (|u_a| + |u_b|)"},
                "detection": "discrete" if self.variant == "overlap_normal" else
                             "discrete_toi_normal",
                "detection_note": "overlaps found once per step on the drifted positions; "
                                  "discrete_toi_normal backs the pair up along its relative "
                                  "path to the touching pose for the normal (velocities as "
                                  "with continuous detection; positions by projection)",
                "solver_iterations": MAX_PASSES,
                "contact_normal": normal,
                "contact_slop": f"gap <= {CONTACT_SLOP:g} (r_a + r_b) counts as touching",
                "ccd": "none: discrete detection after the drift (a sphere moving more than "
                       "about 2 r per step can tunnel)",
                "projection": "one pass: overlapping pairs pushed apart along the centre line, "
                              "depth split by inverse mass; spheres out of walls; velocities "
                              "untouched",
                "broad_phase": f"uniform grid over the bounding box, cell >= 2 r_max (enlarged "
                               f"to fit {CELLS_PER_SPHERE} N + 64 cells), counting sort, 27 "
                               f"neighbour cells",
                "contact_capacity": self.nd["contact_a"].shape[0],
                "wall_impulse": "accumulated impulse walls gave the spheres (observe()['wall_"
                                "impulse'])",
                "determinism": "bit-reproducible: every loop runs serially inside the "
                               "serialised time loop (no atomics race, no parallel sums)"}


MODEL_GROUP = ModelGroup(name="spheres", build=build, claims=claims, parts=PARTS,
                         features=FEATURES, supports=supports, formulations=formulations,
                         integrators=INTEGRATORS)
