"""taichi and the emitter scenes: not ported (births and removals at step boundaries, fixed
slots, refsim.models.emitter); the group says so instead of the parts check's answer."""
from refsim.scene.emitter import emitter_of

from ...common.refusing_group import refusing_group

MODEL_GROUP = refusing_group("taichi emitter kernels are not written yet: the emitter runs on the "
                             "refsim engine only", name="emitter",
                             claims=lambda scene: emitter_of(scene) is not None)
