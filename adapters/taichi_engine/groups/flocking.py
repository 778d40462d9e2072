"""taichi and the flocking scenes: not yet ported (float64 Cucker-Smale kernels are planned,
the model being refsim.models.flocking); the group says so instead of the parts check's
"does not simulate flocking"."""
from refsim.scene.flocking import flocking_of

from ...common.refusing_group import refusing_group

MODEL_GROUP = refusing_group("taichi flocking kernels are not written yet: the Cucker-Smale and "
                             "Reynolds rules run on the refsim engine only",
                             name="flocking", claims=lambda scene: flocking_of(scene) is not None)
