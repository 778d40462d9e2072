"""Particle-field cases (slides 000, 003, 002; docs/models.md#particle-fields): particles moved
by pair forces (n-body gravity, Lennard-Jones), flocking rules, prescribed velocity fields,
gradient descent, implicit-surface sampling and an emitter. One scenario per module; each
carries its exact or conserved reference beside it, with the source in its docstring."""
