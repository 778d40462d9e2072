"""What the engines' particle-field groups share beyond the models: the Lennard-Jones scene
checks and the description of the slide's emitter as printed."""
from __future__ import annotations

import numpy as np

from refsim.scene import Particles
from refsim.scene.lennard_jones import LennardJones

PRINTED = ("as printed (slide 002): k = per_step particles generated every step (rate k/h), "
           "`velocity == g*dt` a comparison: no acceleration, straight lines; lifetime removal "
           "added (the slide removes nothing)")



def supports_scene(scene, engine_name):
    """None, or why the scene's LennardJones setting cannot run (shared with taichi)."""
    part, particles = scene.part(LennardJones), scene.part(Particles)
    if part.box is not None and len(part.box) != scene.dim:
        return (f"{engine_name} lennard_jones: box has {len(part.box)} lengths, the scene is "
                f"{scene.dim}D (one length per axis)")
    if scene.dim == 2 and not (np.all(particles.position[:, 2] == 0)
                               and np.all(particles.velocity[:, 2] == 0)):
        return f"{engine_name} lennard_jones: a 2D scene moves in the plane z = 0 (z, v_z = 0)"
    return None
