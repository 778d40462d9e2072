"""pymunk on free rigid bodies (a `rigid` part alone: the torque-free tops, the spin drift):
unsupported, with the reason. Its pivoted bodies in the x-z plane are the `pivots` group."""
from ...common.refusing_group import refusing_group


def _free_rigid(scene) -> bool:
    return scene.rigid is not None and scene.part_kinds() == {"rigid"}


MODEL_GROUP = refusing_group("pymunk is 2D: free rigid bodies here turn about a tilted or "
                             "changing axis in 3D (a body's angle in a plane cannot hold it)",
                             name="rigid", claims=_free_rigid)
