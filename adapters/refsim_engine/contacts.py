"""The in-house engine's contact step for sphere scenes (`refsim`, feature "contacts"): a
helper of the spheres group (groups/spheres.py), which reads the scene and passes the bodies,
the contact model and the walls; the sim never looks at a scene.

One step of h: gravity kick, then one of three contact formulations:
- `discrete`: drift, find overlaps at the end of the step, impulses for approaching pairs
  (Jacobi passes until none approaches), then project positions out of penetration; a sphere
  overlapping a plate is pushed back to the side its centre was on at the start of the step
  (plate side "approach": it tunnels only when a step carries it past the whole slab);
- `continuous`: time of impact within the step for approaching pairs, walls and plates' faces;
  the impulse is applied at the contact instant (positions corrected by (v' - v)(h - tau)), so
  an isolated impact lands exactly where the exact solution puts it;
- `hard_sphere_seed`: discrete detection with the course slide's hard-sphere velocity update
  exactly as printed, then projection (kept to show what that formula does to momentum and
  energy).
"""
from __future__ import annotations

import numpy as np

from refsim.engine import Sim
from refsim.models import collisions as col
from refsim.models.collision import plates as slab

CONTACT_FORMULATIONS = ("discrete", "continuous", "hard_sphere_seed")
NO_WALLS = np.zeros((0, 3))
NO_WALLS.flags.writeable = False
NO_CONTACTS = (np.zeros(0, int), np.zeros((0, 3)), np.zeros(0))


class ContactSim(Sim):
    """The spheres of `particles` (a Particles part), the planes through `wall_point` with
    normals `wall_normal` ((w, 3) each, w >= 0) and the thin static `plates` (a Plates part or
    None), under `gravity` (3,) and `contact` (a ContactModel), stepped by a gravity kick, then
    the formulation's contact step. The formulation was validated by `Engine.build` (one of
    CONTACT_FORMULATIONS). Walls and plates are the static contacts: `wall_impulse` is the
    total impulse they gave."""

    def __init__(self, dt, formulation, particles, gravity, contact, wall_point=NO_WALLS,
                 wall_normal=NO_WALLS, plates=None):
        self.dt, self.formulation = float(dt), formulation
        self.x, self.v = particles.position.copy(), particles.velocity.copy()
        self.w = particles.angular_velocity.copy()
        self.m, self.r = particles.mass, particles.radius
        self.inv_m = 1.0 / self.m
        inertia = particles.inertia
        self.inv_i = np.divide(1.0, inertia, out=np.zeros_like(inertia), where=inertia > 0)
        self.g = np.asarray(gravity)
        self.e, self.mu = contact.restitution, contact.friction
        self.wall_p, self.wall_n = wall_point, wall_normal  # read-only
        self.plates = plates if plates is not None and len(plates) else None
        self.plate_axes = None if self.plates is None else slab.plate_axes(self.plates.normal)
        self.wall_impulse = np.zeros(3)
        self._step = {"discrete": self._discrete, "continuous": self._continuous,
                      "hard_sphere_seed": self._seed}[formulation]

    def _step_impl(self, n):
        for _ in range(n):
            if self.g.any():
                self.v += self.dt * self.g
            self._step(self.dt)

    # -- formulations ------------------------------------------------------------------------
    def _overlaps(self, x_before=None):
        """Sphere pairs (i, j, n, depth) and static contacts (sphere, normal, depth) of walls
        and plates; a plate pushes out to the side of `x_before` (the start-of-step centres)."""
        i, j = col.candidate_pairs(self.x, self.r)
        pairs = col.sphere_contacts(self.x, self.r, i, j)
        static = NO_CONTACTS
        if len(self.wall_n):
            s, wall, depth = col.wall_contacts(self.x, self.r, self.wall_p, self.wall_n)
            static = (s, self.wall_n[wall], depth)
        if self.plates is not None:
            p = self.plates
            ps, _, pn, pdepth = slab.plate_contacts(self.x, self.r, p.center, p.normal,
                                                    p.thickness, p.half_size, x_before,
                                                    self.plate_axes)
            static = tuple(np.concatenate([a, b]) for a, b in zip(static, (ps, pn, pdepth)))
        return pairs, static

    def _resolve(self, i, j, n, s, normals):
        """Pair impulses until none approaches, then walls and plates; again while they made a
        pair approach (bounded)."""
        for _ in range(10):
            col.resolve_pairs(self.v, self.w, self.inv_m, self.inv_i, self.r, i, j, n,
                              self.e, self.mu)
            impulse = col.resolve_walls(self.v, self.w, self.m, self.inv_i, self.r, s,
                                        normals, self.e, self.mu)
            self.wall_impulse += impulse
            if not impulse.any():
                return

    def _start(self):
        return self.x.copy() if self.plates is not None else None

    def _discrete(self, h):
        x_before = self._start()
        self.x += h * self.v
        (i, j, n, depth), (s, normals, sdepth) = self._overlaps(x_before)
        self._resolve(i, j, n, s, normals)
        col.project_pairs(self.x, self.inv_m, i, j, n, depth)
        col.project_walls(self.x, s, normals, sdepth)

    def _static_impacts(self, speed, h):
        """(sphere, normal, tau) of the walls and plates met within the step."""
        s, wall, wdepth = (col.wall_contacts(self.x, self.r, self.wall_p, self.wall_n,
                                             margin=speed * h) if len(self.wall_n)
                           else (np.zeros(0, int),) * 2 + (np.zeros(0),))
        vn = np.einsum("pk,pk->p", self.v[s], self.wall_n[wall])
        with np.errstate(divide="ignore", invalid="ignore"):
            wtau = np.where(wdepth >= 0, 0.0, -wdepth / -vn)  # distance to touch / approach
        wall_hit = (vn < 0) & (wtau <= h)
        found = (s[wall_hit], self.wall_n[wall[wall_hit]], wtau[wall_hit])
        if self.plates is None:
            return found
        p = self.plates
        ps, _, pn, ptau = slab.plate_time_of_impact(self.x, self.v, self.r, p.center, p.normal,
                                                    p.thickness, p.half_size, h,
                                                    self.plate_axes)
        return tuple(np.concatenate([a, b]) for a, b in zip(found, (ps, pn, ptau)))

    def _continuous(self, h):
        speed = float(np.max(np.linalg.norm(self.v, axis=1))) if len(self.v) else 0.0
        i, j = col.candidate_pairs(self.x, self.r, margin=2 * speed * h)
        tau = col.time_of_impact(self.x[j] - self.x[i], self.v[j] - self.v[i],
                                 self.r[i] + self.r[j], h)
        hit = np.isfinite(tau)
        i, j, tau = i[hit], j[hit], tau[hit]
        s, normals, wtau = self._static_impacts(speed, h)
        xc = self.x[j] - self.x[i] + (self.v[j] - self.v[i]) * tau[:, None]
        n = xc / np.linalg.norm(xc, axis=1)[:, None]
        v_before = self.v.copy()
        x_before = self._start()
        self._resolve(i, j, n, s, normals)
        # move with the old velocity to the contact, with the new one after it
        self.x += h * v_before
        late = np.zeros(len(self.x))
        np.maximum.at(late, np.concatenate([i, j, s]), np.concatenate([h - tau, h - tau,
                                                                         h - wtau]))
        self.x += (self.v - v_before) * late[:, None]
        (pi, pj, pn, depth), (ps, psn, pdepth) = self._overlaps(x_before)
        col.project_pairs(self.x, self.inv_m, pi, pj, pn, depth)
        col.project_walls(self.x, ps, psn, pdepth)

    def _seed(self, h):
        x_before = self._start()
        self.x += h * self.v
        (i, j, n, depth), (s, normals, sdepth) = self._overlaps(x_before)
        col.hard_sphere_seed(self.v, self.x, self.m, i, j)
        self.wall_impulse += col.resolve_walls(self.v, self.w, self.m, self.inv_i, self.r, s,
                                               normals, self.e, 0.0)
        col.project_pairs(self.x, self.inv_m, i, j, n, depth)
        col.project_walls(self.x, s, normals, sdepth)

    # -- contract ----------------------------------------------------------------------------
    def _observe(self):
        return {"x": self.x.copy(), "v": self.v.copy(), "w": self.w.copy(),
                "wall_impulse": self.wall_impulse.copy()}

    def settings(self):
        law = {"discrete": "impulses (Newton restitution, Coulomb stick/slide) at the end of "
                           "the step, in passes over sphere-disjoint pairs until none "
                           "approaches, then projection",
               "continuous": "impulses at the time of impact within the step, then projection",
               "hard_sphere_seed": "the slide's hard-sphere update as printed (u = x1 - x2, "
                                   "unnormalised), then projection"}[self.formulation]
        broad = "all pairs" if len(self.x) < 16 else "uniform grid, cell 2 r_max (sorted ids)"
        out = {"integrator": {"name": "symplectic_euler", "order": 1,
                              "family": "symplectic Euler + contact impulses",
                              "explicit": True, "symplectic": False},
               "contact_model": ("impulse" if self.formulation != "hard_sphere_seed"
                                 else "seed"),
               "detection": "continuous" if self.formulation == "continuous" else "discrete",
               "contact_law": law, "broad_phase": broad, "restitution": self.e,
               "friction": self.mu, "dtype": "float64",
               "stages": (["gravity"] if self.g.any() else []) + [
                   "broad_phase", "narrow_phase", f"contacts:{self.formulation}",
                   "projection", "integrate:symplectic_euler"], "threads": 1}
        if self.plates is not None:
            out["plates"] = ("square slabs, faces only (no rim contacts), dense spheres x "
                             "plates; continuous: time of impact of the centre path with the "
                             "faces")
            if self.formulation != "continuous":
                out["plate_side"] = "approach"  # pushed back to the start-of-step side
                out["plate_projection"] = "face"  # moved out onto that face at the step's end
        return out
