"""taichi on rigid bodies in frictional contact: unsupported, with the reason."""
from ...common.refusing_group import refusing_group

MODEL_GROUP = refusing_group("taichi's rigid kernels have no frictional contact (they follow "
                             "the slides' rigid-body model: Newton-Euler and the orientation)")
