"""The in-house engine on rigid bodies in frictional contact: unsupported, with the reason."""
from ...common.refusing_group import refusing_group

MODEL_GROUP = refusing_group("refsim has no frictional rigid-body contact (the slides' "
                             "rigid-body model has none: Newton-Euler and the orientation only)")
