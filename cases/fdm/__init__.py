"""Finite differences on regular grids (slides 000/001): heat, wave and Poisson equations."""
