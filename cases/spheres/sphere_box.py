"""Spheres in a box: N elastic spheres at random in a closed cube; kinetic energy must stay
exactly E0 (no closed-form trajectory exists for N bodies).

No gravity. N spheres of radius r at random non-overlapping positions (a jittered lattice) in
a cube of side L, set by the volume fraction phi = N (4/3) pi r^3 / L^3, with 6 elastic walls
and random velocities (zero total momentum, mean speed v). Elastic impacts and walls conserve
kinetic energy exactly; the compared observable is the relative kinetic-energy error
|E(t) - E0| / E0. Soft contacts hold energy while compressed, at most the share of spheres in
contact, bounded through the collision rate v / l with Maxwell's mean free path of a dilute
hard-sphere gas, l = 1 / (sqrt 2 n pi (2r)^2). `momentum_drift` is net of the walls' impulse
(NaN where the engine does not report it); `penetration_max` includes the walls. See
`refsim_cases.spheres._impact` for the shared conventions.
"""
from __future__ import annotations

import numpy as np

from refsim_cases.spheres._impact import (
    SPHERE_PARAMS,
    kinetic_energy,
    momentum_drift,
    penetration_max,
    sphere_scene,
    state_energy,
)
from refsim.case import EPS, Case, Param
from refsim.engine import ContactInfo
from refsim.scene import Wall


class SphereBox(Case):
    name = "sphere_box"
    description = "N elastic spheres at random in a closed cube; kinetic energy conserved"
    tags = ("contacts", "rigid", "exact")
    observable, units = "kinetic_error", "of E0"
    params = {
        **SPHERE_PARAMS,
        "n_spheres": Param(100, 2, 1e6, "number of spheres"),
        "fraction": Param(0.05, 0.0, 0.3, "volume fraction", low_inclusive=False),
        "seed": Param(1, 0, 2 ** 31, "random seed"),
    }
    variants = {"box_100": {"n_spheres": 100}, "box_1000": {"n_spheres": 1000}}
    quick_variants = ("box_100",)
    # box_1000 (about 3 minutes of work over every engine and dt) runs by name or with --variant
    default_variants = ("box_100",)
    order_meaningful = False  # elastic impulses conserve energy exactly at any dt

    def validate(self, overrides=None):
        p = super().validate(overrides)
        p["n_spheres"] = int(p["n_spheres"])
        return p

    # -- scene -------------------------------------------------------------------------------
    def box_side(self, p):
        volume = p["n_spheres"] * 4.0 / 3.0 * np.pi * p["radius"] ** 3
        return (volume / p["fraction"]) ** (1.0 / 3.0)

    def free_path(self, p):
        """Mean free path of hard spheres of radius r at volume fraction phi (dilute gas):
        1 / (sqrt 2 n pi (2r)^2) = r / (3 sqrt 2 phi)."""
        return p["radius"] / (3.0 * np.sqrt(2.0) * p["fraction"])

    def initial_state(self, p):
        """Spheres on a jittered lattice (never overlapping), velocities with zero total
        momentum scaled to mean speed v: (x, v, m, w)."""
        rng = np.random.default_rng(int(p["seed"]))
        n, r, side = p["n_spheres"], p["radius"], self.box_side(p)
        per_side = int(np.ceil(n ** (1.0 / 3.0)))
        pitch = side / per_side
        cells = np.stack(np.unravel_index(rng.permutation(per_side ** 3)[:n],
                                          (per_side,) * 3), axis=1)
        jitter = rng.uniform(-1, 1, (n, 3)) * max(0.0, 0.5 * pitch - r) * 0.999
        x = (cells + 0.5) * pitch + jitter
        velocity = rng.normal(size=(n, 3))
        velocity -= velocity.mean(axis=0)
        velocity *= p["speed"] / np.mean(np.linalg.norm(velocity, axis=1))
        return x, velocity, np.full(n, p["mass"]), np.zeros((n, 3))

    def walls(self, p):
        """The cube [0, side]^3: a wall through each face, its normal pointing inwards."""
        side = self.box_side(p)
        walls = []
        for normal in np.eye(3):
            walls.append(Wall(point=(0.0, 0.0, 0.0), normal=normal))
            walls.append(Wall(point=side * normal, normal=-normal))
        return tuple(walls)

    def scene(self, p):
        return sphere_scene(p, *self.initial_state(p), walls=self.walls(p))

    def masses(self, p):
        return np.full(p["n_spheres"], p["mass"])

    # -- time --------------------------------------------------------------------------------
    def t_end(self, p):
        return p["duration"]

    def dts(self, p):
        return [2e-3, 1e-3]

    def reference_dt(self, p):
        return 1e-3

    def sample_dt(self, p):
        return p["duration"] / 50

    def motion_scale(self, p):
        return p["speed"]

    # -- reference, energy, metrics ----------------------------------------------------------
    def reference(self, p, t):
        return {"kinetic_error": np.zeros_like(np.asarray(t, float))}

    def observables(self, p, obs):
        energy = kinetic_energy(self.masses(p), p["radius"], obs)
        return {"kinetic_error": np.abs(energy - energy[0]) / energy[0]}

    def error(self, p, observed, reference):
        return observed["kinetic_error"]

    def energy(self, p, obs):
        return kinetic_energy(self.masses(p), p["radius"], obs)

    def energy_mask(self, p, t):
        return np.ones(len(np.asarray(t)), bool)

    def reference_energy(self, p, t):
        x0, v0, m, w0 = self.initial_state(p)
        return np.full(len(t), state_energy(m, p["radius"], v0, w0))  # elastic throughout

    def energy_scale(self, p):
        x0, v0, m, _ = self.initial_state(p)
        return 0.5 * np.sum(m * np.sum(v0 * v0, axis=1))

    def extra_metrics(self, p, obs, observed, reference):
        return {"momentum_drift": momentum_drift(self.masses(p), obs, walls=True),
                "penetration_max": penetration_max(obs, p["radius"], self.box_side(p))}

    # -- tolerance ---------------------------------------------------------------------------
    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        contact = ContactInfo.of(settings)
        duration = contact.duration_s
        if contact.soft and duration > 0:
            rate = p["speed"] / self.free_path(p)
            return 2 * rate * duration + 1e-6, (
                f"soft contacts hold kinetic energy while compressed: at most the share of "
                f"spheres in contact, 2 x collision rate (v / mean free path = {rate:.3g} "
                f"/s) x contact duration ({duration:.3g} s)")
        n = p["n_spheres"]
        impacts = 2.0 * n * p["speed"] / self.free_path(p) * self.t_end(p)
        bound = 4.0 * EPS * impacts + n * EPS
        return bound, (
            f"elastic impacts conserve kinetic energy exactly: round-off only. An impact "
            f"rounds two spheres' velocities, the total kinetic energy by at most 4 eps "
            f"relative (their share of it is far less); over {impacts:.0f} impacts (twice "
            f"n v / l T, Maxwell's dilute-gas rate: the gas at phi = {p['fraction']:g} "
            f"collides more often, walls reflect exactly), plus n eps for the sum of E: "
            f"{bound:.3g} (a float32 state, 6e-8 per rounding, errs 1e-9..1e-8)")


CASE = SphereBox()
