"""Finite-element cases (slides 001 and 000): P1 meshes against closed forms."""
