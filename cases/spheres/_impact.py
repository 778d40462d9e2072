"""What the sphere contact cases share: the scene of spheres, kinetic energy, momentum and
penetration metrics, and `SingleImpactCase`, the base of the cases whose exact outcome is one
impact (or one ideal sequence of them) between free flights.

Conventions of every contact case: no gravity; spheres of one radius r, solid (inertia
2/5 m r^2); `ContactModel(restitution e, friction mu)`. `momentum_drift` is
max |P(t) - P(0)| / sum m |v0|; where walls exchange momentum it is |P(t) - P(0) - J_walls(t)|
with the wall impulse J_walls the engine reports (the in-house engine does), else NaN.
`penetration_max` is the deepest overlap (sphere-sphere or sphere-wall) over the samples, in m.
`energy_drift` is measured against the exact kinetic energy (e < 1 loses (1 - e^2) of the
normal relative energy at impact).

Tolerances read the engine's `settings()`: "contact_model" is "impulse" (Newton restitution by
impulses), "soft" (spring-damper contact; then "contact_duration_s") or "seed" (the slide's
formula); "detection" is "continuous" (time of impact), "discrete_toi_normal" (found late but
the normal taken at the time of impact) or "discrete" (normal of the overlapped pose).
"""
from __future__ import annotations

import numpy as np

from refsim.case import Case, Param
from refsim.scene import Body, ContactModel, Particles, Scene, Walls

SETTLE = 0.05  # s after first contact before the outcome is compared (soft contacts)


def solid_sphere_inertia(mass, radius):
    """Moment of inertia of solid spheres, 2/5 m r^2 (one per mass)."""
    return 0.4 * np.asarray(mass) * radius ** 2


def sphere_scene(p, x, v, m, w, walls=()) -> Scene:
    """Spheres of radius p["radius"] with the contact model of p (restitution, friction)."""
    contact = ContactModel(restitution=p["restitution"], friction=p["friction"])
    inertia = solid_sphere_inertia(m, p["radius"])
    bodies = tuple(Body(mass=m[i], position=x[i], velocity=v[i], radius=p["radius"],
                        inertia=inertia[i], angular_velocity=w[i], name=f"sphere{i}")
                   for i in range(len(m)))
    return Scene(parts=(Particles.of(bodies), Walls.of(walls)), contact=contact)


def kinetic_energy(m, radius, obs) -> np.ndarray:
    """Translational (and, where the engine observes "w", rotational) kinetic energy per
    sample of stacked observations {"v": (t, n, 3), "w": (t, n, 3)}."""
    energy = 0.5 * np.einsum("j,tjk,tjk->t", m, obs["v"], obs["v"])
    if "w" in obs:
        inertia = solid_sphere_inertia(m, radius)
        energy = energy + 0.5 * np.einsum("j,tjk,tjk->t", inertia, obs["w"], obs["w"])
    return energy


def state_energy(m, radius, v, w) -> float:
    """Kinetic energy of one state: velocities v and angular velocities w, each (n, 3)."""
    inertia = solid_sphere_inertia(m, radius)
    return 0.5 * np.sum(m * np.sum(v * v, axis=1)) + 0.5 * np.sum(inertia * np.sum(w * w,
                                                                                 axis=1))


def momentum_drift(m, obs, walls: bool) -> float:
    """max |P(t) - P(0)| / sum m |v0|, net of the walls' impulse where walls exist (NaN when
    the engine does not report it)."""
    momentum = np.einsum("j,tjk->tk", m, obs["v"])
    if "wall_impulse" in obs:
        momentum = momentum - obs["wall_impulse"]
    elif walls:
        momentum = np.full_like(momentum, np.nan)
    scale = np.sum(m * np.linalg.norm(obs["v"][0], axis=1))
    return float(np.max(np.linalg.norm(momentum - momentum[0], axis=1)) / scale)


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


def penetration_max(obs, radius, side=None) -> float:
    """`penetration` over every sample of stacked positions obs["x"] (t, n, 3)."""
    return float(max(penetration(positions, radius, side) for positions in obs["x"]))


SPHERE_PARAMS = {
    "radius": Param(0.1, 0.0, 10.0, "r (m)", low_inclusive=False),
    "mass": Param(1.0, 0.0, 1e6, "m1 (kg)", low_inclusive=False),
    "speed": Param(1.0, 0.0, 1e3, "v (m/s)", low_inclusive=False),
    "restitution": Param(1.0, 0.0, 1.0, "e"),
    "friction": Param(0.0, 0.0, 10.0, "mu"),
    "duration": Param(1.0, 0.0, 1e4, "s", low_inclusive=False),
}


class SingleImpactCase(Case):
    """Spheres in free flight meeting at the known time `contact_time(p)`, with the exact
    outcome `outcome(p)`. A subclass supplies `initial_state(p)` -> (x, v, m, w), each (n, 3)
    but m (n,), `contact_time(p)` and `outcome(p)` -> (v, w) after the impact.

    `velocity` (m/s, every sphere's velocity, stacked) is compared with the exact one at the
    samples after the impact has finished (t >= t_c + SETTLE, where SETTLE = 0.05 s covers
    soft contacts lasting up to 50 steps of 1 ms): err_* are post-collision velocity errors.
    `position_err` is the largest position error after the impact: it shows where in the step
    a discrete contact was found. No order in dt exists: impulses resolve the impact exactly,
    soft contacts err by their restitution mapping, whatever the step."""
    observable, units = "velocity", "m/s"
    order_meaningful = False
    # the error series holds the samples after the impact only (`error`): its first value is
    # not the state at t = 0, so the core's t = 0 check does not apply
    initial_state_is_reference = False

    def validate(self, overrides=None):
        p = super().validate(overrides)
        if 2 * p["radius"] >= 1.0:
            raise ValueError(f"{self.name}.radius must be < 0.5, got {p['radius']}")
        return p

    def initial_state(self, p):
        raise NotImplementedError

    def contact_time(self, p) -> float:
        raise NotImplementedError

    def outcome(self, p):
        raise NotImplementedError

    def scene(self, p):
        return sphere_scene(p, *self.initial_state(p))

    # -- time --------------------------------------------------------------------------------
    def t_end(self, p):
        return p["duration"]

    def dts(self, p):
        return [4e-3, 2e-3, 1e-3, 5e-4]

    def reference_dt(self, p):
        return 1e-3

    def motion_scale(self, p):
        return p["speed"]

    # -- reference and error -----------------------------------------------------------------
    def reference(self, p, t):
        t = np.asarray(t, float)
        x0, v0, _, _ = self.initial_state(p)
        tc = self.contact_time(p)
        after = (t > tc)[:, None, None]
        v1, _ = self.outcome(p)
        x_c = x0 + v0 * tc
        x = np.where(after, x_c + v1 * (t - tc)[:, None, None], x0 + v0 * t[:, None, None])
        v = np.where(after, v1, v0)
        return {"velocity": v.reshape(len(t), -1), "position": x.reshape(len(t), -1)}

    def observables(self, p, obs):
        n = len(obs["t"])
        return {"velocity": obs["v"].reshape(n, -1), "position": obs["x"].reshape(n, -1),
                "t": np.asarray(obs["t"])}

    def error(self, p, observed, reference):
        post = self.post_impact(p, observed["t"])
        diff = observed["velocity"][post] - reference["velocity"][post]
        return np.linalg.norm(diff, axis=1)

    def post_impact(self, p, t):
        """Samples after the impact has settled (t >= t_c + SETTLE)."""
        return np.asarray(t) >= self.contact_time(p) + SETTLE

    # -- energy and metrics ------------------------------------------------------------------
    def energy(self, p, obs):
        return kinetic_energy(self.initial_state(p)[2], p["radius"], obs)

    def energy_mask(self, p, t):
        """Samples where kinetic energy is compared: outside the impact window (a soft contact
        holds energy in its spring while compressed)."""
        t = np.asarray(t)
        tc = self.contact_time(p)
        return (t < tc) | (t >= tc + SETTLE)

    def reference_energy(self, p, t):
        x0, v0, m, w0 = self.initial_state(p)
        v1, w1 = self.outcome(p)
        before, after = (state_energy(m, p["radius"], v0, w0),
                         state_energy(m, p["radius"], v1, w1))
        return np.where(np.asarray(t) > self.contact_time(p), after, before)

    def energy_scale(self, p):
        x0, v0, m, _ = self.initial_state(p)
        return 0.5 * np.sum(m * np.sum(v0 * v0, axis=1))

    def extra_metrics(self, p, obs, observed, reference):
        out = {"momentum_drift": momentum_drift(self.initial_state(p)[2], obs, walls=False),
               "penetration_max": penetration_max(obs, p["radius"])}
        post = self.post_impact(p, obs["t"])
        diff = observed["position"][post] - reference["position"][post]
        out["position_err"] = float(np.max(np.linalg.norm(diff, axis=1))) if post.any() \
            else float("nan")
        return out
