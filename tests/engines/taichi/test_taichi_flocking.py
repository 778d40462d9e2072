"""taichi refuses the flocking and emitter scenes with its reason (kernels not written yet)."""
from cases.particle_fields.boids import CASE as BOIDS
from cases.particle_fields.sprinkler import CASE as EMITTER
from refsim.registry import get_engine


def test_taichi_refuses_flocking_and_emitter_with_the_reason():
    engine = get_engine("taichi")
    for case, word in ((BOIDS, "flocking"), (EMITTER, "emitter")):
        scene = case.scene(case.variant_params(next(iter(case.variants))))
        reason = engine.supports(scene)
        assert reason is not None and f"taichi {word} kernels are not written yet" in reason
