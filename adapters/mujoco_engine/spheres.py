"""Sphere scenes (features "contacts", "walls"; group "spheres" decides which scenes and
passes the arguments): free spheres, walls, soft contacts.

One free-jointed body per sphere with an explicit `<inertial>` (scene mass, diaginertia = the
scene's 2/5 m r^2; `inertiafromgeom` off, checked after compiling) and a sphere geom; each wall
is a plane geom through its point with z axis = its inward normal. MuJoCo has no restitution
parameter (docs/engine_notes.md#mujoco-no-restitution-parameter: the default solref gives
e ~ 0.13 whatever is asked), so contacts are its soft contacts in the direct form
solref = (-K, -B) with a flat impedance d (solimp dmin = dmax):
- an isolated contact's relative normal acceleration is then exactly -K pos - B vel, whatever
  the masses and d (engine_core_constraint.c stores K/d^2 and B/d, aref = -(B vel + K pos)/d,
  and the solver returns a = d aref when R = (1-d)/d A); K = (pi / (N dt))^2 makes an
  undamped contact last N = CONTACT_STEPS steps at every dt;
- B is calibrated in code: a bisection on B so that the restitution MuJoCo itself produces
  (two spheres head-on at the scene's dt with the scene's integrator), averaged over 32
  contact onsets within a step, equals e; the largest deviation over onsets is reported as
  the residual (cached per process; `restitution`);
- d decides how simultaneous contacts couple (the formulations): "" d = 1e-4, one linear
  spring-dashpot per contact (DEM); "coupled" d = 0.9999, MuJoCo's constraint regime;
- friction mu > 0: condim 3, elliptic cone; the friction rows' damping comes from
  `solreffriction`, which only explicit <pair> elements carry, so frictional scenes list every
  sphere-sphere and sphere-wall pair (at most MAX_FRICTION_SPHERES spheres);
- integrators: Euler, implicit and implicitfast take the same step here; RK4 re-detects and
  re-solves contacts at each stage; discrete (backward Euler on the contact spring) is refused.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .body_plan import BodyPlan
from .contact_params import (CONTACT_STEPS, IMPEDANCE, SOLVER_ITERATIONS, SOLVER_TOLERANCE,
                             VARIANT_NOTES, friction_damping)
from .mjcf import xml_floats
from .restitution import RestitutionMap, restitution_map


def sphere_plan(i, body) -> BodyPlan:
    """A free sphere; qvel0 = (v, w): the free joint's angular velocity is in the body frame,
    which is the world frame at t = 0 (identity orientation)."""
    return BodyPlan("sphere", i, body.mass, body.position, radius=body.radius,
                    inertia=body.inertia, qvel0=body.velocity + body.angular_velocity)


def rotate(quat: np.ndarray, vec: np.ndarray) -> np.ndarray:
    """Rotate each vec (n, 3) by its unit quaternion (n, 4) = (w, x, y, z), MuJoCo's order."""
    w, u = quat[:, :1], quat[:, 1:]
    t = 2.0 * np.cross(u, vec)
    return vec + w * t + np.cross(u, t)


@dataclass(frozen=True)
class ContactSetup:
    """Contact parameters of one sphere scene at one dt and integrator."""

    nbody: int
    wall_points: np.ndarray  # (n_walls, 3): the Walls part's points ((0, 3) without walls)
    wall_normals: np.ndarray  # (n_walls, 3) unit, into free space: the Walls part's normals
    restitution_map: RestitutionMap
    friction: float
    friction_damping: float
    formulation: str

    @property
    def impedance(self) -> float:
        return IMPEDANCE[self.formulation]

    @classmethod
    def make(cls, contact, nbody, wall_points, wall_normals, dt, integrator, formulation):
        """The setup of `nbody` spheres and the given walls under the ContactModel `contact`."""
        rmap = restitution_map(contact.restitution, dt, integrator, IMPEDANCE[formulation])
        mu = contact.friction
        return cls(nbody, wall_points, wall_normals, rmap, mu,
                   friction_damping(dt) if mu > 0 else 0.0, formulation)

    @property
    def condim(self) -> int:
        return 3 if self.friction > 0 else 1

    def _params(self) -> str:
        k, b = self.restitution_map.stiffness, self.restitution_map.damping
        return (f'condim="{self.condim}" solref="{xml_floats(-k)} {xml_floats(-b)}" '
                f'solimp="{self.impedance!r} {self.impedance!r} 0.001 0.5 2" margin="0" '
                f'gap="0"')

    def default_xml(self) -> str:
        """Every geom: the contact parameters; frictional scenes switch automatic contacts off
        (contype = conaffinity = 0) and list their pairs instead."""
        if self.friction > 0:
            return ('<default><geom contype="0" conaffinity="0" friction="0 0 0"/></default>')
        return (f'<default><geom contype="1" conaffinity="1" friction="0 0 0" '
                f'{self._params()}/></default>')

    def walls_xml(self) -> str:
        return "".join(f'<geom name="w{k}" type="plane" pos="{xml_floats(p)}" '
                       f'zaxis="{xml_floats(n)}" size="0 0 1"/>'
                       for k, (p, n) in enumerate(zip(self.wall_points, self.wall_normals)))

    def pairs_xml(self) -> str:
        if self.friction <= 0:
            return ""
        mu = xml_floats(self.friction)
        attrs = (f'{self._params()} friction="{mu} {mu} 0 0 0" '
                 f'solreffriction="0 {xml_floats(-self.friction_damping)}"')
        names = [f"s{i}" for i in range(self.nbody)]
        pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1:]]
        pairs += [(f"w{k}", a) for k in range(len(self.wall_points)) for a in names]
        return "<contact>" + "".join(f'<pair geom1="{a}" geom2="{b}" {attrs}/>'
                                     for a, b in pairs) + "</contact>"

    def describe(self, dt) -> dict:
        k = self.restitution_map.stiffness
        out = {
            "contact_model": "soft",
            "restitution_mapping": self.restitution_map.describe(),
            "solref": [-k, -self.restitution_map.damping],
            "solref_form": "direct (-stiffness, -damping): relative normal acceleration "
                           "-K pos - B vel for an isolated contact",
            "solimp": [self.impedance, self.impedance, 0.001, 0.5, 2.0],
            "solimp_note": "flat impedance (dmin = dmax, so width/midpoint/power are unused); "
                           "d cancels from an isolated contact and decides how simultaneous "
                           "contacts couple",
            "engine_variant": self.formulation or "default",
            "simultaneous_contacts": VARIANT_NOTES[self.formulation],
            "contact_steps": CONTACT_STEPS,
            "contact_duration_s": CONTACT_STEPS * dt,
            "contact_duration_note": "undamped half period pi / sqrt(K); damping shortens it",
            "condim": self.condim, "cone": "elliptic", "margin": 0.0, "gap": 0.0,
            "friction": self.friction,
            "solver": {"name": "Newton", "iterations": SOLVER_ITERATIONS,
                       "tolerance": SOLVER_TOLERANCE, "tolerance_default_replaced": 1e-8,
                       "noslip_iterations": 0, "impratio": 1.0},
            "ccd": "none: MuJoCo finds sphere-sphere and sphere-plane overlaps with analytic "
                   "primitives at the start of each step (no swept or continuous detection; "
                   "nativeccd/multiccd concern convex meshes only)",
            "walls": "plane geoms in the world body, z axis = inward normal (infinite for "
                     "collision)",
            "inertia": "explicit <inertial>: scene mass and diaginertia = scene inertia "
                       "(2/5 m r^2), inertiafromgeom=false, compiled values checked",
            "contacts": "enabled: sphere-sphere and sphere-wall",
        }
        if self.friction > 0:
            out.update(self._describe_friction())
        return out

    def _describe_friction(self) -> dict:
        return {
            "friction_model": (
                "condim 3, elliptic cone, mu on every explicit <pair> (sphere-sphere and "
                "sphere-wall; automatic contacts off); friction rows damped by solreffriction "
                f"(0, -Bf), Bf = 2 sqrt(K) = {self.friction_damping:.6g} 1/s: critical damping "
                "at the contact frequency (MuJoCo's default dampratio 1). MuJoCo's regularised "
                "cone couples sliding friction with the normal force: an impact that slides "
                "rebounds with less normal speed than Newton's law gives"),
            "friction_pairs": (self.nbody * (self.nbody - 1) // 2
                               + self.nbody * len(self.wall_points)),
        }
