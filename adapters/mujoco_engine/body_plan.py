"""One scene body as a MuJoCo body: its joints and their parameters."""
from __future__ import annotations

from dataclasses import dataclass

FORMULATIONS = {
    "particle": "3 slide joints (x, y, z): exact point-mass translation",
    "spring": "1 slide joint along the anchor-body line, joint stiffness/springref",
    "hinge": "1 hinge joint through the anchor: generalized coordinate",
    "sphere": "free joint, sphere geom, explicit inertial",
}


@dataclass(frozen=True)
class BodyPlan:
    kind: str  # "particle", "spring", "hinge" or "sphere"
    index: int
    mass: float
    position: tuple
    axis: tuple = (0.0, 0.0, 0.0)  # slide axis (spring) or hinge axis
    joint_pos: tuple = (0.0, 0.0, 0.0)  # hinge point in the body frame
    stiffness: float = 0.0
    springref: float = 0.0
    damping: float = 0.0
    qvel0: tuple = ()
    radius: float = 0.0  # sphere
    inertia: float = 0.0  # sphere: scalar moment about the centre

    def describe(self) -> dict:
        text = FORMULATIONS[self.kind]
        if self.kind == "sphere":
            return {"body": self.index, "formulation": text, "radius": self.radius,
                    "mass": self.mass, "inertia": self.inertia}
        return {"body": self.index, "formulation": text, "axis": list(self.axis),
                "stiffness": self.stiffness, "springref": self.springref,
                "joint_damping": self.damping}
