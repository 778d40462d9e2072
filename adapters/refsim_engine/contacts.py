"""The in-house engine's contact step for sphere scenes (`refsim`, feature "contacts"): a
helper of the spheres group (groups/spheres.py), which reads the scene and passes the bodies,
the contact model and the walls; the sim never looks at a scene.

One step of h: gravity kick, then one of three contact formulations:
- `discrete`: drift, find overlaps at the end of the step, impulses for approaching pairs
  (Jacobi passes until none approaches), then project positions out of penetration;
- `continuous`: time of impact within the step for approaching pairs and walls; the impulse
  is applied at the contact instant (positions corrected by (v' - v)(h - tau)), so an isolated
  impact lands exactly where the exact solution puts it;
- `hard_sphere_seed`: discrete detection with the course slide's hard-sphere velocity update
  exactly as printed, then projection (kept to show what that formula does to momentum and
  energy).
"""
from __future__ import annotations

import numpy as np

from refsim.engine import Sim
from refsim.models import collisions as col

CONTACT_FORMULATIONS = ("discrete", "continuous", "hard_sphere_seed")
NO_WALLS = np.zeros((0, 3))
NO_WALLS.flags.writeable = False


class ContactSim(Sim):
    """The spheres of `particles` (a Particles part) and the planes through `wall_point` with
    normals `wall_normal` ((w, 3) each, w >= 0), under `gravity` (3,) and `contact` (a
    ContactModel), stepped by a gravity kick, then the formulation's contact step. The
    formulation was validated by `Engine.build` (one of CONTACT_FORMULATIONS)."""

    def __init__(self, dt, formulation, particles, gravity, contact, wall_point=NO_WALLS,
                 wall_normal=NO_WALLS):
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
        self.wall_impulse = np.zeros(3)
        self._step = {"discrete": self._discrete, "continuous": self._continuous,
                      "hard_sphere_seed": self._seed}[formulation]

    def _step_impl(self, n):
        for _ in range(n):
            if self.g.any():
                self.v += self.dt * self.g
            self._step(self.dt)

    # -- formulations ------------------------------------------------------------------------
    def _overlaps(self):
        i, j = col.candidate_pairs(self.x, self.r)
        pairs = col.sphere_contacts(self.x, self.r, i, j)
        walls = col.wall_contacts(self.x, self.r, self.wall_p, self.wall_n) if len(
            self.wall_n) else (np.zeros(0, int),) * 2 + (np.zeros(0),)
        return pairs, walls

    def _resolve(self, i, j, n, s, wall):
        """Pair impulses until none approaches, then walls; again while walls made a pair
        approach (bounded)."""
        for _ in range(10):
            col.resolve_pairs(self.v, self.w, self.inv_m, self.inv_i, self.r, i, j, n,
                              self.e, self.mu)
            impulse = col.resolve_walls(self.v, self.w, self.m, self.inv_i, self.r, s,
                                        self.wall_n[wall], self.e, self.mu)
            self.wall_impulse += impulse
            if not impulse.any():
                return

    def _discrete(self, h):
        self.x += h * self.v
        (i, j, n, depth), (s, wall, wdepth) = self._overlaps()
        self._resolve(i, j, n, s, wall)
        col.project_pairs(self.x, self.inv_m, i, j, n, depth)
        col.project_walls(self.x, s, self.wall_n[wall], wdepth)

    def _continuous(self, h):
        speed = float(np.max(np.linalg.norm(self.v, axis=1))) if len(self.v) else 0.0
        i, j = col.candidate_pairs(self.x, self.r, margin=2 * speed * h)
        tau = col.time_of_impact(self.x[j] - self.x[i], self.v[j] - self.v[i],
                                 self.r[i] + self.r[j], h)
        hit = np.isfinite(tau)
        i, j, tau = i[hit], j[hit], tau[hit]
        s, wall, wdepth = (col.wall_contacts(self.x, self.r, self.wall_p, self.wall_n,
                                             margin=speed * h) if len(self.wall_n)
                           else (np.zeros(0, int),) * 2 + (np.zeros(0),))
        vn = np.einsum("pk,pk->p", self.v[s], self.wall_n[wall])
        with np.errstate(divide="ignore", invalid="ignore"):
            wtau = np.where(wdepth >= 0, 0.0, -wdepth / -vn)  # distance to touch / approach
        wall_hit = (vn < 0) & (wtau <= h)
        s, wall, wtau = s[wall_hit], wall[wall_hit], wtau[wall_hit]
        xc = self.x[j] - self.x[i] + (self.v[j] - self.v[i]) * tau[:, None]
        n = xc / np.linalg.norm(xc, axis=1)[:, None]
        v_before = self.v.copy()
        self._resolve(i, j, n, s, wall)
        # move with the old velocity to the contact, with the new one after it
        self.x += h * v_before
        late = np.zeros(len(self.x))
        np.maximum.at(late, np.concatenate([i, j, s]), np.concatenate([h - tau, h - tau,
                                                                         h - wtau]))
        self.x += (self.v - v_before) * late[:, None]
        (pi, pj, pn, depth), (ps, pw, pdepth) = self._overlaps()
        col.project_pairs(self.x, self.inv_m, pi, pj, pn, depth)
        col.project_walls(self.x, ps, self.wall_n[pw], pdepth)

    def _seed(self, h):
        self.x += h * self.v
        (i, j, n, depth), (s, wall, wdepth) = self._overlaps()
        col.hard_sphere_seed(self.v, self.x, self.m, i, j)
        self.wall_impulse += col.resolve_walls(self.v, self.w, self.m, self.inv_i, self.r, s,
                                               self.wall_n[wall], self.e, 0.0)
        col.project_pairs(self.x, self.inv_m, i, j, n, depth)
        col.project_walls(self.x, s, self.wall_n[wall], wdepth)

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
        return {"integrator": {"name": "symplectic_euler", "order": 1,
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
