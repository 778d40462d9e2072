"""Thin static plates (the Plates part, issue 28 tunnelling) in MuJoCo's sphere scenes.

Each plate is a box geom in the world body: half extents (w/2, half_size, half_size) in its
frame, whose x axis is the plate's normal (`xyaxes` from an in-plane pair), with the same
contact parameters as the walls (the sphere setup's soft contact, margin 0, gap 0).
Formulations of a scene with plates (mujoco 4.0.0, measured in
tests/engines/mujoco/test_mujoco_tunnelling.py):
- "" (discrete): overlaps found at the start of each step. The soft contact lets a fast sphere
  sink about v / sqrt(K) = v N dt / pi deep (N = CONTACT_STEPS), and once its centre is past
  the plate's mid-plane MuJoCo's sphere-box test takes the nearer (far) face: the sphere is
  pushed through. It tunnels from v dt ~ (pi / 2N)(w + 2r), far below the geometric
  (w + 2r) / dt of a detection that only misses;
- "speculative": `<flag speculative="enable"/>` (MuJoCo's speculative contacts: conservative
  advancement gives the time of impact within the step and a synthetic contact distance that
  makes the solver land the sphere on the surface at the step's end). No margin or tolerance
  is set for it (margin 0). It engages only when a step moves the sphere more than
  min(r, w/2): below that the discrete soft contact acts, so where its sink threshold
  (pi / 2N)(w + 2r) is under min(r, w/2) (plates of about r to 4.4 r) the sphere still
  tunnels (r = 5 cm, w = 10 cm: ratios 0.1575-0.2475). A speculative hit lands the sphere at
  the approach speed (its distance to the surface) / dt: it rebounds at e times that, not at
  e times the impact speed (the impact's energy is lost). Under RK4 it fails (spheres at
  0.3 to 100 times (w + 2r) / dt went through; Euler, implicit and implicitfast stop them).
"""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from .mjcf import xml_floats
from .spheres import ContactSetup

FORMULATIONS = ("", "speculative")
SPECULATIVE_FLAG = '<option><flag speculative="enable"/></option>'
DISCRETE_NOTE = (
    "discrete: overlaps at the start of each step; the soft contact (K = (pi / (N dt))^2) lets "
    "a sphere sink ~ v N dt / pi, and past the plate's mid-plane MuJoCo's sphere-box test "
    "takes the far face and pushes it through: tunnels from v dt ~ (pi / 2N)(w + 2r)")
SPECULATIVE_NOTE = (
    "speculative contacts (flag speculative=enable): conservative advancement finds the time "
    "of impact within the step, a synthetic contact distance makes the solver land the "
    "sphere on the surface at the step's end; margin 0 (none needed). Engages only when a "
    "step moves the sphere more than min(r, w/2); slower spheres meet the discrete soft "
    "contact, which tunnels from v dt ~ (pi / 2N)(w + 2r): plates of about r to 4.4 r still "
    "let spheres through. A hit rebounds at e (distance to the surface) / dt, not e v")


def in_plane_axes(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """An orthonormal pair (u, v) with u x v = normal, per row of `normal` (p, 3) unit."""
    pick = np.where(np.abs(normal[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(normal, pick)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return u, np.cross(normal, u)


@dataclass(frozen=True)
class PlateContactSetup(ContactSetup):
    """The sphere scene's contact setup with the plates as box geoms, and the detection."""

    plate_center: np.ndarray  # (p, 3)
    plate_normal: np.ndarray  # (p, 3) unit
    plate_thickness: np.ndarray  # (p,)
    plate_half_size: np.ndarray  # (p,)
    speculative: bool

    @classmethod
    def with_plates(cls, base: ContactSetup, plates, formulation: str):
        """`base` (a ContactSetup of the default impedance) with the `plates` part's boxes and
        the `formulation` ("" or "speculative")."""
        if formulation not in FORMULATIONS:
            raise ValueError(f"mujoco plates formulation must be one of {list(FORMULATIONS)}, "
                             f"got {formulation!r}")
        own = {f.name: getattr(base, f.name) for f in fields(ContactSetup)}
        return cls(**own, plate_center=plates.center, plate_normal=plates.normal,
                   plate_thickness=plates.thickness, plate_half_size=plates.half_size,
                   speculative=formulation == "speculative")

    def default_xml(self) -> str:
        """The base defaults, preceded by the speculative flag where asked (MJCF merges a
        second <option> into the first)."""
        return (SPECULATIVE_FLAG if self.speculative else "") + super().default_xml()

    def plates_xml(self) -> str:
        u, _ = in_plane_axes(self.plate_normal)
        rows = zip(self.plate_center, self.plate_normal, u, self.plate_thickness,
                   self.plate_half_size)
        # the box frame: x = the normal, y = u (MuJoCo takes z = x cross y)
        return "".join(f'<geom name="p{k}" type="box" pos="{xml_floats(c)}" '
                       f'xyaxes="{xml_floats(np.concatenate([n, uk]))}" '
                       f'size="{xml_floats([0.5 * w, h, h])}"/>'
                       for k, (c, n, uk, w, h) in enumerate(rows))

    def walls_xml(self) -> str:
        return super().walls_xml() + self.plates_xml()

    def pairs_xml(self) -> str:
        """Frictional scenes list every pair: the base's, and each plate with each sphere."""
        if self.friction <= 0:
            return ""
        base = super().pairs_xml()
        mu = xml_floats(self.friction)
        attrs = (f'{self._params()} friction="{mu} {mu} 0 0 0" '
                 f'solreffriction="0 {xml_floats(-self.friction_damping)}"')
        extra = "".join(f'<pair geom1="p{k}" geom2="s{i}" {attrs}/>'
                        for k in range(len(self.plate_center)) for i in range(self.nbody))
        return base.replace("</contact>", extra + "</contact>")

    def describe(self, dt) -> dict:
        out = super().describe(dt)
        out.update({
            "detection": "continuous" if self.speculative else "discrete",
            "plate_side": "nearest",
            "plate_side_note": ("MuJoCo's sphere-box test takes the face of least "
                                "penetration (through, once the centre is past the "
                                "mid-plane); the soft contact lets a sphere sink ~ v N dt / "
                                "pi first, so it reaches the mid-plane from v dt ~ "
                                "(pi / 2N)(w + 2r), not w/2 + r"),
            "engine_variant": "speculative" if self.speculative else "default",
            "speculative_contacts": "enabled" if self.speculative else "disabled (default)",
            "ccd": SPECULATIVE_NOTE if self.speculative else DISCRETE_NOTE,
            "plates": (f"{len(self.plate_center)} static box geoms in the world body, half "
                       "extents (w/2, half_size, half_size) in a frame whose x axis is the "
                       "plate normal; the walls' soft contact parameters, margin 0, gap 0"),
            "contacts": "enabled: sphere-sphere, sphere-wall and sphere-plate",
        })
        if self.speculative and self.restitution_map.integrator == "rk4":
            out["speculative_rk4"] = (
                "measured failing: under RK4 speculative contacts stop only the slower "
                "spheres (r 5 cm, w 2 cm, 1 ms: ratios 0.3 to 100 of (w + 2r) / dt went "
                "through, as with discrete detection; Euler and the implicit integrators "
                "stopped them all)")
        if self.speculative:
            out["speculative_restitution"] = (
                "a speculative hit leaves the approach speed (distance to the surface) / dt "
                "and the sphere rebounds at e times that, not e times its impact speed "
                "(measured e = 1, gap 3 mm at 1 ms: 2.94 m/s back whatever the impact "
                "speed); restitution_mapping holds for discrete contacts only")
        if self.friction > 0:
            out["friction_pairs"] += self.nbody * len(self.plate_center)
        return out
