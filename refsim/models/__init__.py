"""Physics kernels of the in-house engine: forces, constraints and the systems built from them.

Everything here is vectorised numpy over bodies and over any leading batch axes, and knows
nothing about time stepping (that is `refsim.integrators`).
"""
