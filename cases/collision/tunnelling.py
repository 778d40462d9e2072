"""Tunnelling: small fast spheres against a thin plate, discrete against continuous detection
(issue 28, case 5; slide 001's "discrete vs continuous"). A time-stepping case.

Geometry. One static plate (Plates part): mid-plane through the origin, normal n = +x,
thickness w, square of half side H in the y-z plane. n spheres of radius r, the i-th at
z_i = (i - (n - 1) / 2) s (s = 4 r: never touching each other; H leaves every sphere more than
s + 2 r inside the rim), all at x0 = -(w/2 + r + delta): a step ends (t = 0) with each sphere's
front a hair delta = hair (w + 2 r) before the entry face, the worst phase. Sphere i moves at
v_i = ratio_i (w + 2 r) / dt along +x, dt = `step` the case's one step; no gravity, contact
model (restitution e, friction 0). Ratios (`sweep` = 0): 0.25, 0.499, 0.5005, 0.502, 0.75,
0.999, 1.0005, 1.002, 1.5, 2, 3, 100 (bracketing both thresholds below to 0.15 %); `sweep` = m:
m ratios log-spaced over [0.25, 3], plus 100.

Reference: the exact trajectory, the sphere meets the entry face at t_c = delta / v and leaves
it at -e v: x = x0 + v t, then -(w/2 + r) - e v (t - t_c).

Theory of the detection (exact, worst phase). End-of-step positions are x0 + k v dt; the first
after t = 0 that passes the entry extent is step k* = floor(delta / (v dt)) + 1, at
d* = x0 + k* v dt along n. It overlaps the slab iff d* < w/2 + r; since the slab's extent along
n is w + 2 r, it is missed entirely iff v dt >= w + 2 r + delta. Where an overlap found at the
end of a step pushes the sphere (the engine's settings "plate_side"):
- "approach": back to the side its centre came from (refsim's discrete detection: the side of
  the start-of-step centre). Tunnels iff ratio > 1 + hair (v dt > w + 2 r + delta);
- "nearest" (the default where an engine declares none): out of the face of least
  penetration, so a centre past the mid-plane is pushed through. Tunnels iff ratio >
  1/2 + hair (v dt > w/2 + r + delta).
What happens to the overlap (settings "plate_projection"):
- "face" (refsim; the default where an engine declares none): the sphere is moved out onto the
  face at t = k* dt (the entry face when bounced, the far one when pushed through) and leaves
  it at -e v (or flies on at v): e v (k* dt - t_c) behind the exact one;
- "none": the velocity alone changes (an impulse, no positional correction in that step), so
  the sphere leaves from where the step ended, d*, at -e v (pushed-through ones fly on freely):
  e v (k* dt - t_c) + (d* + w/2 + r) behind (pybullet and pymunk behave so: they find the
  overlap at the start of the next step and reverse the velocity before moving).
Continuous detection (settings "detection": "continuous": the time of
impact on the slab faces swept by the centre path) never tunnels and is exact.

Observable `position`: every sphere's centre; the error per sample (the tolerance column
err_max) is max |x_i - x_exact_i| / (v_i T) over the spheres whose centre ends on the near side
(bounced), in units of each sphere's own travel v_i T (T = steps dt): a tunnelled sphere's
error is its whole travel, which says nothing a verdict can bound; the tunnelled spheres are
judged by the outcome rule below instead. Extra columns: `tunnelled` (spheres whose
centre ends beyond the mid-plane), `threshold_ratio` (the lowest tunnelling ratio, NaN where
none tunnelled), `bounce_ratio` (the highest non-tunnelling ratio), `bounce_depth_min` and
`bounce_depth_max` (over the spheres ending on the near side, the share of its overlap a sphere
kept when it bounced: (P + w/2 + r) / (d* + w/2 + r), P = x(T) + e v (T - k* dt) the point it
left from at k* dt; 0 for "face", 1 for "none", per sphere).

Verdict (consistency). Bound: the theory's own error (its bounced spheres' trajectory against
the exact one, e (k* dt - t_c) / T, max over the steps, per the declared detection and plate
side; 0 for continuous), plus round-off 4 N eps (|x0| + v T) / (v T) (N steps: three roundings
of the position a step and the contact-time arithmetic); a soft (spring-damper) contact adds
its stated restitution residual de (T - t_c) / T and (1 + e) (T_c + dt) / T for the contact's
duration and a step of detection. `consistency_checks`: the tunnelled spheres are exactly the
theory's (the count equals the theory's and the lowest tunnelling ratio is above the theory's
threshold: then the set is the theory's), and for discrete impulse contacts both bounce depths
the declared projection's (0 or 1) within round-off, 4 N eps S / min (d* + w/2 + r) (S = max
|x0| + v T; a sphere's departure point P errs by the rounding of x(T)). T = 100 steps
keeps a soft contact's duration over T resolved (MuJoCo's 0.1 s: bound 0.23 < 1/2).

Measured on refsim (`refsim run --case tunnelling --engine refsim`): discrete tunnels 5,
lowest ratio 1.002, highest bounce 1.0005 (theory: above 1.001), err 0.00999 = its bound;
swept ratios bracket it: 0.99976 to 1.0123 (--param sweep=200), 0.99918 to 1.00167 (variant
sweep, 1000 ratios);
continuous: 0 tunnelled, err 1.9e-15 (bound 1.2e-13). Planted once (tests/cases/
test_tunnelling.py): continuous with the plate's time of impact at the step's end: err 0.00999
against 1.2e-13; the plate 10 % thicker in the scene than in the theory: discrete tunnels 4
(from 1.5) against 5, continuous err 8e-5; refsim's push-out switched to the face of least
penetration while declaring "approach": 9 tunnel from 0.502 (the "nearest" theory's set,
consistent when declared so); its projection off while declaring "face": bounce depth 1 (the
"none" theory's, consistent when declared so). Each inconsistent.
"""
from __future__ import annotations

import numpy as np

from refsim.case import EPS, Case, Param
from refsim.engine import ContactInfo
from refsim.scene import Body, ContactModel, Particles, Plates, Scene

RATIOS = (0.25, 0.499, 0.5005, 0.502, 0.75, 0.999, 1.0005, 1.002, 1.5, 2.0, 3.0, 100.0)
PLATE_SIDES = ("approach", "nearest")
PROJECTIONS = ("face", "none")


class Tunnelling(Case):
    name = "tunnelling"
    description = ("small fast spheres against a thin plate: discrete detection tunnels above "
                   "v dt = w + 2r (or w/2 + r), continuous never")
    tags = ("contacts", "collision", "exact")
    observable, units = "position", "of each sphere's travel v T"
    params = {
        "radius": Param(0.05, 0.0, 1.0, "r (m)", low_inclusive=False),
        "thickness": Param(0.02, 0.0, 1.0, "plate thickness w (m)", low_inclusive=False),
        "step": Param(0.01, 0.0, 1.0, "the case's time step dt (s)", low_inclusive=False),
        "hair": Param(1e-3, 0.0, 0.1, "delta / (w + 2r): the gap before the entry face at "
                                      "t = 0", low_inclusive=False),
        "restitution": Param(1.0, 0.0, 1.0, "e"),
        # 100 steps: a soft contact's duration (MuJoCo's 0.1 s here) over T stays resolved
        "steps": Param(100, 2, 1e4, "steps run (T = steps dt)"),
        "sweep": Param(0, 0, 1e5, "0: the listed ratios; m: m ratios log-spaced in [0.25, 3] "
                                  "plus 100"),
    }
    variants = {"threshold": {}, "threshold_e0.5": {"restitution": 0.5},
                "sweep": {"sweep": 1000}}
    quick_variants = default_variants = ("threshold",)
    alternatives_variants = ("threshold",)
    order_meaningful = False  # the outcome is decided per step, no convergence in dt

    def validate(self, overrides=None):
        p = super().validate(overrides)
        p["steps"], p["sweep"] = int(p["steps"]), int(p["sweep"])
        return p

    # -- geometry ----------------------------------------------------------------------------
    def ratios(self, p) -> np.ndarray:
        if p["sweep"] == 0:
            return np.array(RATIOS)
        return np.append(np.geomspace(0.25, 3.0, p["sweep"]), 100.0)

    def extent(self, p) -> float:
        """w + 2 r: the slab's extent along n for a sphere's centre."""
        return p["thickness"] + 2 * p["radius"]

    def delta(self, p) -> float:
        return p["hair"] * self.extent(p)

    def speeds(self, p) -> np.ndarray:
        return self.ratios(p) * self.extent(p) / p["step"]

    def start(self, p) -> np.ndarray:
        """(n, 3) initial centres."""
        n, r = len(self.ratios(p)), p["radius"]
        x = np.zeros((n, 3))
        x[:, 0] = -(p["thickness"] / 2 + r + self.delta(p))
        x[:, 2] = (np.arange(n) - (n - 1) / 2) * 4 * r  # the x-z plane: 2D engines too
        return x

    def half_size(self, p) -> float:
        r = p["radius"]
        return float(np.max(np.abs(self.start(p)[:, 2]))) + 6 * r

    def scene(self, p):
        x, v = self.start(p), self.speeds(p)
        r, m = p["radius"], 1.0
        inertia = 0.4 * m * r * r
        bodies = tuple(Body(mass=m, position=x[i], velocity=(v[i], 0.0, 0.0), radius=r,
                            inertia=inertia, name=f"sphere{i}") for i in range(len(v)))
        plate = Plates(center=np.zeros((1, 3)), normal=[[1.0, 0.0, 0.0]],
                       thickness=[p["thickness"]], half_size=[self.half_size(p)])
        return Scene(parts=(Particles.of(bodies), plate),
                     contact=ContactModel(restitution=p["restitution"], friction=0.0))

    def bodies(self, p):
        return len(self.ratios(p))

    # -- time --------------------------------------------------------------------------------
    def t_end(self, p):
        return p["steps"] * p["step"]

    def dts(self, p):
        return [p["step"]]

    def reference_dt(self, p):
        return p["step"]

    def motion_scale(self, p):
        return 1.0  # the error is relative to each sphere's travel

    # -- reference and theory ----------------------------------------------------------------
    def contact_time(self, p) -> np.ndarray:
        return self.delta(p) / self.speeds(p)

    def reference(self, p, t):
        t = np.asarray(t, float)[:, None]
        x = np.broadcast_to(self.start(p), (len(t),) + self.start(p).shape).copy()
        v, tc, e = self.speeds(p), self.contact_time(p), p["restitution"]
        face = -(p["thickness"] / 2 + p["radius"])
        x[:, :, 0] = np.where(t <= tc, x[:, :, 0] + v * t, face - e * v * (t - tc))
        vel = np.zeros_like(x)
        vel[:, :, 0] = np.where(t <= tc, v, -e * v)
        return {"position": x, "velocity": vel}

    def first_overlap(self, p):
        """(k*, d*): the first step whose end passes the entry extent, and the centre's
        coordinate along n there."""
        v, dt = self.speeds(p), p["step"]
        k = np.floor(self.delta(p) / (v * dt)) + 1
        return k, self.start(p)[:, 0] + k * v * dt

    def theory_tunnels(self, p, detection="discrete", side="nearest") -> np.ndarray:
        """Which spheres end beyond the plate under the detection and plate side."""
        if detection == "continuous":
            return np.zeros(len(self.ratios(p)), bool)
        _, d = self.first_overlap(p)
        missed = d >= p["thickness"] / 2 + p["radius"]
        return missed | (d >= 0.0) if side == "nearest" else missed

    def theory_threshold(self, p, detection="discrete", side="nearest") -> float:
        """The ratio above which spheres tunnel (inf: never)."""
        if detection == "continuous":
            return np.inf
        return (0.5 if side == "nearest" else 1.0) + p["hair"]

    def theory_trajectory(self, p, t, detection="discrete", side="nearest",
                          projection="face") -> np.ndarray:
        """Centres' coordinate along n (t, n) under the detection theory."""
        t = np.asarray(t, float)[:, None]
        if detection == "continuous":
            return self.reference(p, t[:, 0])["position"][:, :, 0]
        v, e, dt = self.speeds(p), p["restitution"], p["step"]
        half = p["thickness"] / 2 + p["radius"]
        k, d = self.first_overlap(p)
        tk = k * dt
        free = self.start(p)[:, 0] + v * t
        kept = projection == "none"
        bounce = np.where(t < tk, free, (d if kept else -half) - e * v * (t - tk))
        through = free if kept else np.where(t < tk, free, half + v * (t - tk))
        missed = d >= half
        pushed = ~missed & (d >= 0.0) & (side == "nearest")
        return np.where(missed, free, np.where(pushed, through, bounce))

    # -- observables, error, metrics ---------------------------------------------------------
    def observables(self, p, obs):
        return {"position": np.asarray(obs["x"]), "velocity": np.asarray(obs["v"]),
                "t": np.asarray(obs["t"])}

    def error(self, p, observed, reference):
        """max |x_i - x_exact_i| / (v_i T) over the spheres ending on the near side (NaN where
        none does: nothing bounced to compare)."""
        x = np.asarray(observed["position"])
        near = x[-1, :, 0] <= 0.0
        if not near.any():
            return np.full(len(x), np.nan)
        travel = self.speeds(p) * self.t_end(p)
        rel = np.linalg.norm(x - np.asarray(reference["position"]), axis=2) / travel
        return np.max(rel[:, near], axis=1)

    def extra_metrics(self, p, obs, observed, reference):
        ratios = self.ratios(p)
        x_end = np.asarray(observed["position"])[-1]
        beyond = x_end[:, 0] > 0.0
        out = {"tunnelled": float(np.sum(beyond)),
               "threshold_ratio": float(np.min(ratios[beyond])) if beyond.any() else np.nan,
               "bounce_ratio": float(np.max(ratios[~beyond])) if (~beyond).any() else np.nan}
        depth = self.bounce_depth(p, x_end[:, 0])[~beyond]
        out["bounce_depth_min"] = float(np.min(depth)) if len(depth) else np.nan
        out["bounce_depth_max"] = float(np.max(depth)) if len(depth) else np.nan
        return out

    def bounce_depth(self, p, x_end) -> np.ndarray:
        """Per sphere, the share of its overlap d* + w/2 + r it kept when it left at k* dt:
        (P + w/2 + r) / (d* + w/2 + r), P = x(T) + e v (T - k* dt)."""
        k, d = self.first_overlap(p)
        half = p["thickness"] / 2 + p["radius"]
        point = x_end + p["restitution"] * self.speeds(p) * (self.t_end(p) - k * p["step"])
        return (point + half) / (d + half)

    def energy(self, p, obs):
        return 0.5 * np.einsum("tjk,tjk->t", obs["v"], obs["v"])  # unit masses

    def energy_scale(self, p):
        return 0.5 * float(np.sum(self.speeds(p) ** 2))

    def reference_energy(self, p, t):
        t = np.asarray(t, float)[:, None]
        v, tc, e = self.speeds(p), self.contact_time(p), p["restitution"]
        return 0.5 * np.sum(np.where(t <= tc, v, e * v) ** 2, axis=1)

    # -- verdicts ----------------------------------------------------------------------------
    @staticmethod
    def detection_of(settings) -> tuple[str, str, str]:
        """(detection, plate side, plate projection) an engine declares."""
        s = settings if isinstance(settings, dict) else {}
        return (ContactInfo.of(settings).detection, str(s.get("plate_side", "nearest")),
                str(s.get("plate_projection", "face")))

    def roundoff(self, p) -> float:
        """Position round-off (m) of the sphere travelling farthest: 4 N eps S."""
        scale = float(np.max(np.abs(self.start(p))) + np.max(self.speeds(p)) * self.t_end(p))
        return 4 * p["steps"] * EPS * scale

    def roundoff_relative(self, p) -> float:
        """The same per sphere, relative to its travel: max 4 N eps (|x0| + v T) / (v T)."""
        travel = self.speeds(p) * self.t_end(p)
        scale = np.max(np.abs(self.start(p)), axis=1) + travel
        return float(np.max(4 * p["steps"] * EPS * scale / travel))

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        detection, side, projection = self.detection_of(settings)
        contact = ContactInfo.of(settings)
        t = np.arange(p["steps"] + 1) * p["step"]
        theory = self.theory_trajectory(p, t, detection, side, projection)
        exact = self.reference(p, t)["position"][:, :, 0]
        travel = self.speeds(p) * self.t_end(p)
        bounced = ~self.theory_tunnels(p, detection, side)
        own = float(np.max(np.abs(theory - exact)[:, bounced] / travel[bounced])) \
            if bounced.any() else 0.0
        bound = own + self.roundoff_relative(p)
        if detection == "continuous":
            reason = ("continuous detection (time of impact on the slab faces): the exact "
                      "trajectory")
        else:
            behind = "e v (k* dt - t_c)" if projection == "face" else \
                "e v (k* dt - t_c) + d* + w/2 + r"
            reason = (f"discrete detection, plate side {side!r}, projection {projection!r}: "
                      f"the theory's own error {own:.6g} of the travel (its bounced spheres "
                      f"leave at the end of the step k* that overlaps, {behind} behind the "
                      f"exact ones, over v T)")
        reason += (f"; plus round-off 4 N eps (|x0| + v T) / (v T) = "
                   f"{self.roundoff_relative(p):.3g}")
        if contact.soft:
            e = p["restitution"]
            period = self.t_end(p)
            soft = float(np.max(contact.restitution_residual * (period - self.contact_time(p))
                                / period + (1 + e) * (contact.duration_s + dt) / period))
            bound += soft
            reason += (f"; plus the soft contact's stated restitution residual de (T - t_c) / "
                       f"T and (1 + e) (T_c + dt) / T for its duration and a step: "
                       f"{soft:.3g}")
        return bound, reason

    def consistency_checks(self, p, row, settings, stacked=None):
        detection, side, projection = self.detection_of(settings)
        reasons = []
        if detection != "continuous" and side not in PLATE_SIDES:
            return [f"plate_side must be one of {list(PLATE_SIDES)}, got {side!r}"]
        if detection != "continuous" and projection not in PROJECTIONS:
            return [f"plate_projection must be one of {list(PROJECTIONS)}, got {projection!r}"]
        expected = int(np.sum(self.theory_tunnels(p, detection, side)))
        threshold = self.theory_threshold(p, detection, side)
        got, lowest = row.get("tunnelled", np.nan), row.get("threshold_ratio", np.nan)
        if not got == expected or (expected and not lowest > threshold):
            reasons.append(
                f"tunnelled {got:g} (lowest ratio {lowest:g}) where the theory ({detection}, "
                f"plate side {side!r}) tunnels {expected} spheres, every ratio above "
                f"{threshold:g}")
        if detection == "discrete" and not ContactInfo.of(settings).soft:
            want = 0.0 if projection == "face" else 1.0
            k, d = self.first_overlap(p)
            bounced = ~self.theory_tunnels(p, detection, side)
            depth = d[bounced] + p["thickness"] / 2 + p["radius"]
            tol = self.roundoff(p) / float(np.min(depth)) if bounced.any() else 0.0
            low, high = row.get("bounce_depth_min", np.nan), row.get("bounce_depth_max", np.nan)
            if bounced.any() and not (abs(low - want) <= tol and abs(high - want) <= tol):
                reasons.append(f"bounce depth {low:.3g}..{high:.3g}: the bounced spheres did "
                               f"not leave from where projection {projection!r} puts them "
                               f"({want:g} of their overlap kept, round-off {tol:.3g})")
        return reasons


CASE = Tunnelling()
