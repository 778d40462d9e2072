"""A model group that only refuses, with a reason: by default it claims rigid bodies in frictional contact (`RigidShapes` with walls and a
contact model, e.g. cases/contact_rolling/rolling_disc.py) only to refuse them with a reason, for an
engine whose rigid-body model has no contact. Without it the parts check would answer "does
not simulate rigid, rigid_shapes", as if the engine had no rigid bodies at all."""
from __future__ import annotations

from refsim.engine import ModelGroup
from refsim.scene.rigid_shapes import shapes_of


def _claims(scene) -> bool:
    return scene.rigid is not None and shapes_of(scene) is not None


def refusing_group(reason: str, name: str = "contact_rolling", claims=_claims) -> ModelGroup:
    """A group that claims the scenes `claims` accepts (default: rigid bodies with shapes) and
    supports none of them, saying `reason`."""
    def build(engine, scene, dt, integrator, variant):
        raise ValueError(reason)  # never reached: supports() refuses every scene it claims

    return ModelGroup(name=name, build=build, claims=claims, parts=None, features=None,
                      supports=lambda engine, scene, integrator: reason)
