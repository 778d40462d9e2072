"""Colliding spheres: head-on and oblique pairs, Newton's cradle, and a box of N spheres.

No gravity. Radius r, masses m1 and m2 = ratio * m1, restitution e, Coulomb friction mu.

- `pair` (head-on when the impact parameter b = 0, oblique otherwise): sphere 1 at
  (-0.5, 0, 0) moving at (+v, 0, 0), sphere 2 at (0.5, 0, b) moving at (-v, 0, 0). They touch at
  t_c = (1 - sqrt(4 r^2 - b^2)) / (2 v) with unit normal n = (sqrt(4 r^2 - b^2), 0, b) / (2 r).
  Exact outcome of a frictionless impact with restitution e (Newton's law along n):
  j = (1 + e) m1 m2 / (m1 + m2) ((v1 - v2) . n), v1' = v1 - j/m1 n, v2' = v2 + j/m2 n.
  Head-on with v1 = 1, v2 = -1: equal masses give (-e, e); 1:3 gives (-2, 0) at e = 1 and
  (-1.25, -0.25) at e = 0.5 (ENGINE_NOTES.md).
- `cradle`: a striker at (-0.5, 0, 0) moving at +v into 4 touching spheres at rest from
  x = 0.5 (five spheres, e = 1). Ideal outcome: the striker and the first three stop, the last
  sphere leaves at v (pairwise impacts one after another). An engine that treats the
  simultaneous contacts as one system departs (a rigid block of 4 m: -0.6 v, 0.4 v x 4; a
  spring chain: the pulse spreads); err_* report that departure. What every correct engine
  must keep, whichever way it resolves simultaneous contacts, is momentum and, at e = 1,
  kinetic energy: the cradle's tolerance bounds `conservation_err`, the larger of the momentum
  drift and the relative kinetic-energy change after the impacts.
- `box`: N spheres at random non-overlapping positions in a cube of side L (volume fraction
  phi) with 6 elastic walls and random velocities (zero total momentum, mean speed v).

Observables and metrics. `velocity` (m/s, every sphere's velocity, stacked) is compared with
the exact one at samples after the impact has finished (t >= t_c + settle, where settle = 0.05
s covers soft contacts lasting up to 50 steps of 1 ms): err_* are post-collision velocity
errors. `position_err` is the largest position error after the impact: it shows where in the
step a discrete contact was found. `momentum_drift` is max |P(t) - P(0)| / sum m |v0|; for the
box, walls exchange momentum, so it is |P(t) - P(0) - J_walls(t)| where the engine reports the
wall impulse J_walls (the in-house engine does), else NaN. `energy_drift` is measured against
the exact kinetic energy (e < 1 loses (1 - e^2) of the normal relative energy at impact).
`penetration_max` is the deepest overlap (sphere-sphere or sphere-wall) over the samples, in m.
For the box, the compared observable is the relative kinetic-energy error |E(t) - E0| / E0
(no closed-form trajectory exists for N bodies).

Tolerances read the engine's `settings()`: "contact_model" is "impulse" (Newton restitution by
impulses), "soft" (spring-damper contact; then "contact_duration_s") or "seed" (the slide's
formula); "detection" is "continuous" (time of impact), "discrete_toi_normal" (found late but
the normal taken at the time of impact) or "discrete" (normal of the overlapped pose, which
earns the tilted-normal allowance on oblique impacts).
"""
from __future__ import annotations

import numpy as np

from refsim.case import Case, Param
from refsim.scene import Body, ContactModel, Scene, Wall

SETTLE = 0.05  # s after first contact before the outcome is compared (soft contacts)


class CollidingSpheres(Case):
    name = "colliding_spheres"
    description = "sphere pairs (head-on, oblique), Newton's cradle, N spheres in a box"
    tags = ("contacts", "rigid", "exact")
    observable, units = "velocity", "m/s"
    params = {
        "layout": Param("pair", choices=("pair", "cradle", "box")),
        "radius": Param(0.1, 0.0, 10.0, "r (m)", low_inclusive=False),
        "mass": Param(1.0, 0.0, 1e6, "m1 (kg)", low_inclusive=False),
        "ratio": Param(1.0, 0.0, 1e6, "m2 / m1", low_inclusive=False),
        "speed": Param(1.0, 0.0, 1e3, "v (m/s)", low_inclusive=False),
        "restitution": Param(1.0, 0.0, 1.0, "e"),
        "friction": Param(0.0, 0.0, 10.0, "mu"),
        "impact": Param(0.0, 0.0, 10.0, "impact parameter b (m), < 2 r"),
        "spin": Param(0.0, -1e4, 1e4, "sphere 1 angular velocity about y (rad/s)"),
        "n_spheres": Param(100, 2, 1e6, "box: number of spheres"),
        "fraction": Param(0.05, 0.0, 0.3, "box: volume fraction", low_inclusive=False),
        "seed": Param(1, 0, 2 ** 31, "box: random seed"),
        "duration": Param(1.0, 0.0, 1e4, "s", low_inclusive=False),
    }
    variants = {
        "head_on": {},
        "head_on_e0.5": {"restitution": 0.5},
        "head_on_1to3": {"ratio": 3.0},
        "head_on_1to3_e0.5": {"ratio": 3.0, "restitution": 0.5},
        "oblique": {"impact": 0.1},
        "oblique_friction": {"impact": 0.1, "friction": 0.3, "spin": 20.0},
        # r = 1/8: centres 2r apart are exact in binary, so the resting spheres touch exactly
        # (with r = 0.1 round-off makes some pairs overlap by 6e-17 m and others gap)
        "cradle": {"layout": "cradle", "radius": 0.125},
        "box_100": {"layout": "box", "n_spheres": 100},
        "box_1000": {"layout": "box", "n_spheres": 1000},
    }
    quick_variants = ("head_on", "oblique", "cradle", "box_100")
    # box_1000 (about 3 minutes of work over every engine and dt) runs by name or with --variant
    default_variants = ("head_on", "head_on_e0.5", "head_on_1to3", "head_on_1to3_e0.5",
                        "oblique", "oblique_friction", "cradle", "box_100")

    # -- scene -------------------------------------------------------------------------------
    def validate(self, overrides=None):
        p = super().validate(overrides)
        if p["layout"] == "pair" and p["impact"] >= 2 * p["radius"]:
            raise ValueError(f"{self.name}.impact must be in [0, 2 radius) = [0, "
                             f"{2 * p['radius']:g}), got {p['impact']}")
        if p["layout"] != "box" and 2 * p["radius"] >= 1.0:
            raise ValueError(f"{self.name}.radius must be < 0.5 for the pair and cradle "
                             f"layouts, got {p['radius']}")
        p["n_spheres"] = int(p["n_spheres"])
        return p

    def scene(self, p):
        contact = ContactModel(restitution=p["restitution"], friction=p["friction"])
        x, v, m, w = self._initial(p)
        inertia = 0.4 * m * p["radius"] ** 2  # solid sphere, 2/5 m r^2
        bodies = tuple(Body(mass=m[i], position=x[i], velocity=v[i], radius=p["radius"],
                            inertia=inertia[i], angular_velocity=w[i], name=f"sphere{i}")
                       for i in range(len(m)))
        return Scene(bodies=bodies, contact=contact, walls=self._walls(p),
                     meta={"layout": p["layout"]})

    def _initial(self, p):
        if p["layout"] == "box":
            return self._box(p)
        v, r = p["speed"], p["radius"]
        if p["layout"] == "pair":
            x = np.array([[-0.5, 0.0, 0.0], [0.5, 0.0, p["impact"]]])
            vel = np.array([[v, 0.0, 0.0], [-v, 0.0, 0.0]])
            m = np.array([p["mass"], p["mass"] * p["ratio"]])
        else:
            x = np.zeros((5, 3))
            x[0, 0] = -0.5
            x[1:, 0] = 0.5 + 2 * r * np.arange(4)
            vel = np.zeros((5, 3))
            vel[0, 0] = v
            m = np.full(5, p["mass"])
        w = np.zeros_like(x)
        w[0, 1] = p["spin"]
        return x, vel, m, w

    def free_path(self, p):
        """Mean free path of hard spheres of radius r at volume fraction phi (dilute gas):
        1 / (sqrt 2 n pi (2r)^2) = r / (3 sqrt 2 phi)."""
        return p["radius"] / (3.0 * np.sqrt(2.0) * p["fraction"])

    def box_side(self, p):
        volume = p["n_spheres"] * 4.0 / 3.0 * np.pi * p["radius"] ** 3
        return (volume / p["fraction"]) ** (1.0 / 3.0)

    def _box(self, p):
        """Spheres on a jittered lattice (never overlapping), velocities with zero total
        momentum scaled to mean speed v."""
        rng = np.random.default_rng(int(p["seed"]))
        n, r, side = p["n_spheres"], p["radius"], self.box_side(p)
        per_side = int(np.ceil(n ** (1.0 / 3.0)))
        pitch = side / per_side
        cells = np.stack(np.unravel_index(rng.permutation(per_side ** 3)[:n],
                                          (per_side,) * 3), axis=1)
        jitter = rng.uniform(-1, 1, (n, 3)) * max(0.0, 0.5 * pitch - r) * 0.999
        x = (cells + 0.5) * pitch + jitter
        vel = rng.normal(size=(n, 3))
        vel -= vel.mean(axis=0)
        vel *= p["speed"] / np.mean(np.linalg.norm(vel, axis=1))
        return x, vel, np.full(n, p["mass"]), np.zeros((n, 3))

    def _walls(self, p):
        if p["layout"] != "box":
            return ()
        side = self.box_side(p)
        walls = []
        for axis in range(3):
            normal = np.eye(3)[axis]
            walls.append(Wall(point=(0.0, 0.0, 0.0), normal=normal))
            walls.append(Wall(point=side * normal, normal=-normal))
        return tuple(walls)

    # -- time --------------------------------------------------------------------------------
    def t_end(self, p):
        return p["duration"]

    def dts(self, p):
        return [4e-3, 2e-3, 1e-3, 5e-4] if p["layout"] != "box" else [2e-3, 1e-3]

    def reference_dt(self, p):
        return 1e-3

    def sample_dt(self, p):
        return p["duration"] / (50 if p["layout"] == "box" else 400)

    def motion_scale(self, p):
        return p["speed"]

    # -- reference ---------------------------------------------------------------------------
    def contact_time(self, p):
        r, v = p["radius"], p["speed"]
        if p["layout"] == "pair":
            return (1.0 - np.sqrt(4 * r * r - p["impact"] ** 2)) / (2 * v)
        if p["layout"] == "cradle":
            return (1.0 - 2 * r) / v
        return 0.0

    def outcome(self, p):
        """Exact post-impact (velocities, angular velocities), each (nbody, 3), of the pair
        (Newton restitution along n; with friction, the Coulomb stick/slide impulse law of
        Guendelman, Bridson & Fedkiw 2003 for one impact) or the ideal cradle."""
        x0, v0, m, w0 = self._initial(p)
        v1, w1 = v0.copy(), w0.copy()
        if p["layout"] == "cradle":
            v1[0], v1[-1] = v0[-1], v0[0]
            return v1, w1
        r, b, e, mu = p["radius"], p["impact"], p["restitution"], p["friction"]
        n = np.array([np.sqrt(4 * r * r - b * b), 0.0, b]) / (2 * r)
        arm1, arm2 = r * n, -r * n  # centre -> contact point
        u = (v0[1] + np.cross(w0[1], arm2)) - (v0[0] + np.cross(w0[0], arm1))
        un = u @ n
        pn = -(1 + e) * un / (1 / m[0] + 1 / m[1])
        impulse = pn * n
        ut = u - un * n
        slide = np.linalg.norm(ut)
        if mu > 0 and slide > 0:
            inertia = 0.4 * m * r * r
            k_t = 1 / m[0] + 1 / m[1] + r * r / inertia[0] + r * r / inertia[1]
            impulse = impulse - min(slide / k_t, mu * pn) * ut / slide
        v1[0] -= impulse / m[0]
        v1[1] += impulse / m[1]
        inertia = 0.4 * m * r * r
        w1[0] -= np.cross(arm1, impulse) / inertia[0]
        w1[1] += np.cross(arm2, impulse) / inertia[1]
        return v1, w1

    def reference(self, p, t):
        t = np.asarray(t, float)
        if p["layout"] == "box":
            return {"kinetic_error": np.zeros_like(t)}
        x0, v0, _, _ = self._initial(p)
        tc = self.contact_time(p)
        after = (t > tc)[:, None, None]
        v1, _ = self.outcome(p)
        x_c = x0 + v0 * tc
        x = np.where(after, x_c + v1 * (t - tc)[:, None, None], x0 + v0 * t[:, None, None])
        v = np.where(after, v1, v0)
        return {"velocity": v.reshape(len(t), -1), "position": x.reshape(len(t), -1)}

    def observables(self, p, obs):
        n = len(obs["t"])
        if p["layout"] == "box":
            e = self._kinetic(p, obs)
            return {"kinetic_error": np.abs(e - e[0]) / e[0]}
        return {"velocity": obs["v"].reshape(n, -1), "position": obs["x"].reshape(n, -1),
                "t": np.asarray(obs["t"])}

    def error(self, p, observed, reference):
        if p["layout"] == "box":
            return observed["kinetic_error"]
        post = self._post_mask(p, observed["t"])
        diff = observed["velocity"][post] - reference["velocity"][post]
        return np.linalg.norm(diff, axis=1)

    def _post_mask(self, p, t):
        return np.asarray(t) >= self.contact_time(p) + SETTLE

    # -- energy, momentum, penetration -------------------------------------------------------
    def _kinetic(self, p, obs):
        m = self._masses(p)
        ke = 0.5 * np.einsum("j,tjk,tjk->t", m, obs["v"], obs["v"])
        if "w" in obs:
            inertia = 0.4 * m * p["radius"] ** 2
            ke = ke + 0.5 * np.einsum("j,tjk,tjk->t", inertia, obs["w"], obs["w"])
        return ke

    def _masses(self, p):
        return self._initial(p)[2] if p["layout"] != "box" else np.full(p["n_spheres"],
                                                                         p["mass"])

    def energy(self, p, obs):
        return self._kinetic(p, obs)

    def energy_mask(self, p, t):
        """Samples where kinetic energy is compared: outside the impact window (a soft contact
        holds energy in its spring while compressed)."""
        t = np.asarray(t)
        if p["layout"] == "box":
            return np.ones(len(t), bool)
        tc = self.contact_time(p)
        return (t < tc) | (t >= tc + SETTLE)

    def reference_energy(self, p, t):
        x0, v0, m, w0 = self._initial(p)
        inertia = 0.4 * m * p["radius"] ** 2
        spin = 0.5 * np.sum(inertia * np.sum(w0 * w0, axis=1))
        e0 = 0.5 * np.sum(m * np.sum(v0 * v0, axis=1)) + spin
        if p["layout"] == "box":
            return np.full(len(t), e0)  # elastic walls and impacts
        v1, w1 = self.outcome(p)
        e1 = 0.5 * np.sum(m * np.sum(v1 * v1, axis=1)) + 0.5 * np.sum(
            inertia * np.sum(w1 * w1, axis=1))
        return np.where(np.asarray(t) > self.contact_time(p), e1, e0)

    def energy_scale(self, p):
        x0, v0, m, _ = self._initial(p)
        return 0.5 * np.sum(m * np.sum(v0 * v0, axis=1))

    def extra_metrics(self, p, obs, observed, reference):
        m = self._masses(p)
        p_t = np.einsum("j,tjk->tk", m, obs["v"])
        if "wall_impulse" in obs:
            p_t = p_t - obs["wall_impulse"]
        elif p["layout"] == "box":
            p_t = np.full_like(p_t, np.nan)
        scale = np.sum(m * np.linalg.norm(obs["v"][0], axis=1))
        out = {"momentum_drift": float(np.max(np.linalg.norm(p_t - p_t[0], axis=1)) / scale),
               "penetration_max": float(max(penetration(obs["x"][k], p["radius"],
                                                        self.box_side(p) if p["layout"] == "box"
                                                        else None)
                                            for k in range(len(obs["t"]))))}
        if p["layout"] != "box":
            post = self._post_mask(p, obs["t"])
            diff = observed["position"][post] - reference["position"][post]
            out["position_err"] = float(np.max(np.linalg.norm(diff, axis=1))) if post.any() \
                else float("nan")
        if p["layout"] == "cradle":
            energy = self._kinetic(p, obs)
            post = self._post_mask(p, obs["t"])
            change = float(np.max(np.abs(energy[post] - energy[0])) / energy[0])
            out["conservation_err"] = max(out["momentum_drift"], change)
        return out

    # -- tolerance ---------------------------------------------------------------------------
    def tolerance_column(self, p):
        return "conservation_err" if p["layout"] == "cradle" else self.tolerance_norm

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        settings = settings or {}
        contact = settings.get("contact_model", "impulse")
        v, e = p["speed"], p["restitution"]
        if p["layout"] == "cradle":
            return self._cradle_tolerance(contact, settings)
        if p["layout"] == "box":
            duration = float(settings.get("contact_duration_s", 0.0))
            if contact == "soft" and duration > 0:
                rate = v / self.free_path(p)
                return 2 * rate * duration + 1e-6, (
                    f"soft contacts hold kinetic energy while compressed: at most the share of "
                    f"spheres in contact, 2 x collision rate (v / mean free path = {rate:.3g} "
                    f"/s) x contact duration ({duration:.3g} s)")
            return 1e-6, ("elastic impacts conserve kinetic energy exactly; 1e-6 allows the "
                          "round-off of ~1e4 impacts")
        if contact == "soft":
            return 0.1 * (1 + e) * v, (
                "soft (spring-damper) contact: the restitution obtained from a damping ratio is "
                "approximate, +9 % to -10 % (ENGINE_NOTES.md), on a velocity change (1+e) v")
        tol, reason = 1e-9 * v, ("impulse contact with Newton's restitution law (and Coulomb "
                                 "stick/slide): the exact outcome to round-off")
        if settings.get("detection", "discrete") == "discrete" and p["impact"] > 0:
            v_rel = 2 * v
            tol += (1 + e) * v_rel * v_rel * dt / p["radius"]
            reason += (f"; plus discrete detection: the pair is found up to one step late, "
                       f"overlapped by up to v_rel dt, which tilts the contact normal by up to "
                       f"v_rel dt / (2 r) and the outcome by (1 + e) v_rel times twice that")
        return tol, reason


    @staticmethod
    def _cradle_tolerance(contact, settings):
        if contact == "soft":
            residual = float(settings.get("restitution_mapping", {}).get("residual_max", 0.0))
            return 8 * residual + 1e-8, (
                f"momentum and energy conserved up to the soft contact's restitution error: "
                f"4 impacts in turn, each carrying the whole energy, each with |e - 1| <= "
                f"{residual:.2g} (the engine's calibration residual), change it by at most "
                f"8 x that")
        return 1e-8, ("momentum and kinetic energy conserved (e = 1): any resolution of the "
                      "simultaneous contacts by elastic impulses keeps both; 1e-8 covers "
                      "iterative solvers' residuals")


def penetration(x, radius, side=None) -> float:
    """Deepest overlap among spheres of equal radius (and with the cube [0, side]^3)."""
    from scipy.spatial import cKDTree
    depth = 0.0
    pairs = cKDTree(x).query_pairs(2 * radius, output_type="ndarray")
    if len(pairs):
        gap = np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1)
        depth = max(depth, float(np.max(2 * radius - gap)))
    if side is not None:
        depth = max(depth, float(np.max(radius - x)), float(np.max(x + radius - side)))
    return max(depth, 0.0)


CASE = CollidingSpheres()
